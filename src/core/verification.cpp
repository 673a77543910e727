#include "verification.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <tuple>
#include <utility>

#include <omp.h>

#include <Eigen/Eigenvalues>

#include "mac_registration/core/pose_error.hpp"
#include "neighbour_grid.hpp"
#include "refinement.hpp"

namespace mac_registration {
namespace {

// Far hypotheses scored on what the reported pose leaves unexplained, highest full score first. The best
// rival of a chance alignment is among the first few; 64 bound the cost at 64 passes over the
// correspondences (~1 ms for 5000).
constexpr int kRivalsExamined = 64;

// The evidence terms, in log-odds. Each is +1 or so where its signal looks like a right pose and falls
// linearly with the signal, unbounded below where a signal contradicts the pose, so that one clear
// contradiction outweighs the support of the others. The anchors are physical expectations, checked on
// the labelled evaluation of BENCHMARKS.md:
// - rival ratio: a right pose explains the consensus and no distant pose explains much of the rest; pure
//   chance puts the best rival at 0.75-1.0 of the best, right poses mostly below 0.5. Even odds at 0.7;
//   +3 at most (a pose with no rival at all can still be contradicted by the clouds).
constexpr double kRivalEvenOdds = 0.7, kRivalSlope = 10.0, kRivalMost = 3.0;
// - free space: a right pose leaves only sensor noise, moving objects and, for fused RGB-D fragments, a
//   camera that moved while fusing in the other scan's free space: up to ~1.5 % measured; each further
//   percent costs 5 points.
constexpr double kFreeSpaceAllowed = 0.015, kFreeSpaceSlope = 500.0;
// - aligned overlap: below 15 % of the source on the target, too little is shared to confirm a pose.
constexpr double kOverlapEvenOdds = 0.15, kOverlapSlope = 10.0;
// - seen on surface: where the target's sensor looked, a right pose puts the source on its surfaces or
//   behind them (occluded); a wrong one mostly behind, outside the room or the street. Even odds at 50 %.
constexpr double kSeenEvenOdds = 0.5, kSeenSlope = 6.0;

// - chance: a consensus no larger than unrelated matches give one of the hypotheses tried (significance
//   0) is no evidence for its pose, however the clouds look (a shuffled-target set's chance pose can lay
//   planes on planes). Free from a significance of ln(1000) (one in a thousand expected by chance; right
//   poses measured: >= 14 nats on the synthetic grid, >= 114 on 3DMatch FPFH sets, >= 118 on lidar), then
//   one log-odds point per nat below, so that at one chance consensus expected (0 nats) it outweighs all
//   the other terms together; never for the pose: sets of wrong FPFH matches stand far above chance too.
constexpr double kChanceFree = 6.907755278982137;  // ln(1000)
// - surface agreement: on a right pose the source's surfaces lie along the target's (normals within 30
//   deg, measured: >= 67 % of the on-surface keypoints indoors, >= 71 % outdoors); an object-scale cloud
//   put into a street scan meets its surfaces at random angles, 1 - cos 30 deg = 13 % by chance, and is
//   "on" them only because tau is a good part of its size. Free from 45 %; at the chance level it costs
//   as much as all the other terms can give together (kMostSupport), linearly in between. Never for the
//   pose: planes laid on planes agree at wrong poses too.
constexpr double kMostSupport = kRivalMost + 3.0;  // the rival term and the three cloud terms at their best
constexpr double kAgreementFree = 0.45, kAgreementChance = 0.1339745962155614;  // 1 - cos 30 deg
constexpr double kAgreementSlope = kMostSupport / (kAgreementFree - kAgreementChance);

// The shape of the consensus and the fine alignment, weighed from labelled outcomes rather than set from
// physical expectations alone (doc/decisions/verification-fitted-terms.md): each anchor and slope below was
// chosen by tools/fit_verification_terms.py on 2600 registered cases (3DMatch and 3DLoMatch of four scenes,
// the verification's indoor pairs, negatives and synthetic sets, KITTI-like pairs, NCLT keyframes) as the
// values that accept the most right poses at the fewest wrong ones (a wrong success counted as five right
// ones lost); leaving one group out, six of eight folds chose the same values.
// - inlier planarity (l3 / l2 of the inliers' spread) as a share of the scene's (of all matched source
//   points): a consensus on one plane of a scene that is not flat (one wall matched onto another) supports a
//   pose turned or slid along it as well as the right one; a flat scene (a road ahead of a car, planarity
//   0.0006) gives a flat consensus at the right pose too. Free from 0.02 of the scene's, then 4 log-odds
//   points per e-fold below. Never for the pose: a well-spread consensus can still be a wrong one.
constexpr double kPlanarityFree = 0.02, kPlanaritySlope = 4.0, kPlanarityFloor = 1e-9;

// The inliers' planarity as a share of the matched points' own (floored: a consensus of three points
// is a plane whatever the scene).
double relativePlanarity(const VerificationSignals& s) {
  return std::max(s.inlier_planarity, kPlanarityFloor) / std::max(s.scene_planarity, kPlanarityFloor);
}

// - fine alignment move: a right pose is only polished by the fine alignment (3DMatch: median 0.3 tau,
//   95 % below 1.5 tau; sparse lidar keyframes, whose global poses are coarser: median 0.8 tau); a near miss
//   slides into the surfaces' own fit and a wrong basin leads further. Free up to 1.5 tau, then 4 points per
//   tau.
constexpr double kMoveFree = 1.5, kMoveSlope = 4.0;
// - ... unless the correspondences follow the move: where the fine pose keeps at least 80 % as many of
//   their inliers as the pose they gave, the move polished a coarse pose (sparse keyframes' consensus of
//   20-40 matches spread over metres) rather than leaving it; the anchor was chosen by the same tool,
//   doc/decisions/move-followed-by-correspondences.md.
constexpr double kMoveFollowed = 0.8;
// - ... or where the move settled with the source lying on the target: a sparse scan against an
//   accumulated cloud (a submap, a map) gets a coarse consensus that the fine alignment carries several tau
//   into a pose where at least 80 % of the source has a target surface within tau, keeping some of the
//   correspondences' inliers.
constexpr double kSettledOverlap = 0.8;
// - a fine alignment still moving when its steps ran out slides along a surface or out of a wrong basin
//   (half the wrong successes; 6 % of right poses on 3DMatch): 2 points.
constexpr double kUnsettled = 2.0;

// The reported score's metric on one residual, 0 beyond tau (as HypothesisEvaluator scores).
double closeness(double residual, double tau, ScoreMetric metric) {
  if (!(residual < tau)) return 0.0;
  const double c = (tau - residual) / tau;
  switch (metric) {
    case ScoreMetric::kMAE:
      return c;
    case ScoreMetric::kMSE:
      return c * c;
    case ScoreMetric::kInlierCount:
      break;
  }
  return 1.0;
}

std::string percent(double share) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(share < 0.1 ? 1 : 0) << 100.0 * share << " %";
  return text.str();
}

std::string successSummary(const MacResult& r) {
  std::ostringstream text;
  text << r.counters.inliers << " inliers of " << r.counters.correspondences - r.counters.dropped_non_finite
       << " correspondences, score " << r.score << ", confidence " << std::fixed << std::setprecision(2)
       << r.confidence;
  return text.str();
}

// ln P(X >= k) for X ~ Poisson(lambda): the upper tail summed from k while it decreases, else one minus
// the lower terms; -inf when lambda is 0 and k > 0.
double logPoissonTail(std::size_t k, double lambda) {
  if (k == 0) return 0.0;
  if (!(lambda > 0.0)) return -std::numeric_limits<double>::infinity();
  const double kd = double(k);
  const auto logTerm = [&](double m) { return m * std::log(lambda) - lambda - std::lgamma(m + 1.0); };
  if (kd > lambda) {
    double sum = 1.0, ratio = 1.0;  // terms relative to P(X = k)
    for (double m = kd + 1.0; m < kd + 10000.0; m += 1.0) {
      ratio *= lambda / m;
      sum += ratio;
      if (ratio < 1e-15 * sum) break;
    }
    return logTerm(kd) + std::log(sum);
  }
  double lower = 0.0;
  for (std::size_t m = 0; m < k; ++m) lower += std::exp(logTerm(double(m)));
  return std::log(std::max(1.0 - lower, 1e-300));
}

struct RivalCandidate {
  int hypothesis = 0;
  double exclusive_score = 0.0;
};

}  // namespace

PointMoments pointMoments(const Eigen::Matrix3Xd& points) {
  PointMoments m;
  const Eigen::Index n = points.cols();
  if (n == 0) return m;
  m.mean = points.rowwise().mean();
  m.second = points * points.transpose() / double(n);
  return m;
}

double rmsDisplacement(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const PointMoments& m) {
  const Eigen::Matrix3d A = a.linear() - b.linear();
  const Eigen::Vector3d t = a.translation() - b.translation();
  // E|A s + t|^2 = tr(A E[s s^T] A^T) + 2 t^T A E[s] + |t|^2
  const double squared = (A * m.second * A.transpose()).trace() + 2.0 * t.dot(A * m.mean) + t.squaredNorm();
  return std::sqrt(std::max(squared, 0.0));
}

double chanceInliers(const CorrespondenceSet& c, const Eigen::Isometry3d& T, double tau, int num_threads) {
  const Eigen::Index n = c.target_points.cols();
  if (n == 0 || c.source_points.cols() != n || !(tau > 0.0)) return 0.0;
  const NeighbourGrid<double> grid(
      NeighbourGrid<double>::Points(c.target_points.data(), 3, n, Eigen::OuterStride<>(3)), tau);
  const double tau2 = tau * tau;
  const int threads = num_threads > 0 ? num_threads : omp_get_max_threads();
  // Integer counts: the total is the same in any order, so the same whatever the thread count.
  std::int64_t pairs = 0;
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : pairs)
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d p = T * c.source_points.col(i);
    if (!p.allFinite()) continue;
    std::size_t ranges[9][2];
    const int rows = grid.candidateRanges(p, ranges);
    for (int r = 0; r < rows; ++r) {
      for (std::size_t s = ranges[r][0]; s < ranges[r][1]; ++s)
        pairs += (Eigen::Vector3d(grid.x(s), grid.y(s), grid.z(s)) - p).squaredNorm() < tau2;
    }
  }
  return double(pairs) / double(n);
}

namespace {

// l3 / l2 and l2 / l1 of the covariance of the source points of the correspondences `counted` marks (all
// when it is empty); 0 / 0 for fewer than three.
std::pair<double, double> sourceShape(const CorrespondenceSet& c, const std::vector<char>& counted) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  std::size_t count = 0;
  for (Eigen::Index i = 0; i < c.source_points.cols(); ++i) {
    if (!counted.empty() && !counted[std::size_t(i)]) continue;
    const Eigen::Vector3d p = c.source_points.col(i);
    if (!p.allFinite()) continue;
    sum += p;
    outer += p * p.transpose();
    ++count;
  }
  if (count < 3) return {0.0, 0.0};
  const Eigen::Vector3d mean = sum / double(count);
  const Eigen::Matrix3d covariance = outer / double(count) - mean * mean.transpose();
  const Eigen::Vector3d l =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvalues();  // ascending
  const auto ratio = [](double a, double b) { return b > 0.0 ? std::max(0.0, a) / b : 0.0; };
  return {ratio(l[0], l[1]), ratio(l[1], l[2])};
}

}  // namespace

double chanceSignificance(std::size_t inliers, double chance_inliers, std::size_t hypotheses) {
  return -std::log(double(std::max<std::size_t>(hypotheses, 1))) - logPoissonTail(inliers, chance_inliers);
}

void measureCorrespondenceSignals(const CorrespondenceSet& c, const std::vector<ScoredHypothesis>& hypotheses,
                                  const HypothesisEvaluator& evaluator, const MacParams& params,
                                  const StopFlag* stop, MacResult& result) {
  const PointMoments moments = pointMoments(c.source_points);
  const double tau = params.evaluation.inlier_threshold;
  const double distinct = params.verification.distinct_pose_factor * tau;
  const Eigen::Isometry3d& best = result.T_target_source;

  std::vector<int> order(hypotheses.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return hypotheses[a].score.score > hypotheses[b].score.score; });

  // What the reported pose explains is no evidence for a rival: a hypothesis near it shares its inliers,
  // a chance alignment elsewhere has inliers of its own.
  // Residuals are compared with tau as square roots of the squares, the same doubles as residuals(); only
  // squares below a hair over tau^2 can have a root below tau (the hair is far above the roots' rounding),
  // so the others need no root, and add nothing.
  const double near_tau2 = tau * tau * (1.0 + 1e-9);
  const auto residualBelowTau = [&](double squared) {
    return squared < near_tau2 && std::sqrt(squared) < tau;
  };
  std::vector<double> squared;
  evaluator.squaredResiduals(best, squared);
  std::vector<char> explained(squared.size());
  for (std::size_t i = 0; i < squared.size(); ++i) explained[i] = residualBelowTau(squared[i]);
  // The first kRivalsExamined hypotheses far from the best, by score; their exclusive scores on the
  // threads, each summed in correspondence order by one thread.
  std::vector<RivalCandidate> rivals;
  for (const int h : order) {
    if (int(rivals.size()) >= kRivalsExamined) break;
    if (rmsDisplacement(hypotheses[h].T_target_source, best, moments) > distinct) rivals.push_back({h, 0.0});
  }
  const int threads = params.num_threads > 0 ? params.num_threads : omp_get_max_threads();
#pragma omp parallel num_threads(threads) if (rivals.size() > 1)
  {
    std::vector<double> rival_squared;
#pragma omp for schedule(dynamic, 1)
    for (int r = 0; r < int(rivals.size()); ++r) {
      if (stopRequested(stop)) continue;
      evaluator.squaredResiduals(hypotheses[rivals[r].hypothesis].T_target_source, rival_squared);
      double exclusive = 0.0;
      for (std::size_t i = 0; i < rival_squared.size(); ++i) {
        if (!explained[i] && rival_squared[i] < near_tau2)
          exclusive += closeness(std::sqrt(rival_squared[i]), tau, params.evaluation.metric);
      }
      rivals[r].exclusive_score = exclusive;
    }
  }
  std::stable_sort(rivals.begin(), rivals.end(), [](const RivalCandidate& a, const RivalCandidate& b) {
    return a.exclusive_score > b.exclusive_score;
  });

  VerificationSignals& signals = result.verification;
  signals.rival_ratio = 0.0;
  if (!rivals.empty() && result.score > 0.0) {
    const Eigen::Isometry3d& rival = hypotheses[rivals[0].hypothesis].T_target_source;
    signals.rival_ratio = rivals[0].exclusive_score / result.score;
    signals.rival_rotation_deg = rotationErrorDeg(best, rival);
    signals.rival_displacement = rmsDisplacement(best, rival, moments);
  }

  std::tie(signals.inlier_planarity, signals.inlier_linearity) = sourceShape(c, explained);
  signals.scene_planarity = sourceShape(c, {}).first;
  signals.chance_inliers = chanceInliers(c, best, tau, params.num_threads);
  signals.chance_significance =
      chanceSignificance(result.counters.inliers, signals.chance_inliers, hypotheses.size());

  // The distinct rivals, refined, as alternatives a caller can disambiguate with other knowledge.
  result.alternatives.clear();
  std::vector<Eigen::Isometry3d> kept{best};
  const auto farFromKept = [&](const Eigen::Isometry3d& T) {
    return std::all_of(kept.begin(), kept.end(),
                       [&](const Eigen::Isometry3d& k) { return rmsDisplacement(T, k, moments) > distinct; });
  };
  // Many refined rivals fall into a pose already listed, so a dozen refinements can go into three
  // alternatives. They are refined a batch at a time on the threads: the next rivals still far from
  // every pose kept (kept only grows, so one near it now stays near it), then accepted in order as one
  // at a time would, re-checked against what the batch added. The same alternatives on any thread count.
  std::vector<int> batch;
  std::vector<RefinementOutcome> refined;
  for (std::size_t next = 0; next < rivals.size();) {
    if (result.alternatives.size() >= params.verification.max_alternatives || stopRequested(stop)) break;
    batch.clear();
    for (; next < rivals.size() && int(batch.size()) < threads; ++next) {
      if (farFromKept(hypotheses[rivals[next].hypothesis].T_target_source))
        batch.push_back(rivals[next].hypothesis);
    }
    refined.assign(batch.size(), RefinementOutcome{});
#pragma omp parallel for schedule(static, 1) num_threads(threads) if (batch.size() > 1)
    for (int k = 0; k < int(batch.size()); ++k) {
      const ScoredHypothesis& h = hypotheses[batch[k]];
      refined[k] = refineTransform(h.T_target_source, h.score, c, evaluator, params.evaluation,
                                   params.refinement, stop);
    }
    for (std::size_t k = 0; k < batch.size(); ++k) {
      if (result.alternatives.size() >= params.verification.max_alternatives || stopRequested(stop)) break;
      if (!farFromKept(hypotheses[batch[k]].T_target_source)) continue;
      const RefinementOutcome& r = refined[k];
      if (!farFromKept(r.T_target_source)) continue;  // it fell into a pose already listed
      kept.push_back(r.T_target_source);
      PoseAlternative alternative;
      alternative.T_target_source = r.T_target_source;
      alternative.score = r.score.score;
      alternative.inliers = r.score.inliers;
      alternative.score_ratio = result.score > 0.0 ? alternative.score / result.score : 0.0;
      alternative.rotation_deg = rotationErrorDeg(best, r.T_target_source);
      alternative.displacement = rmsDisplacement(best, r.T_target_source, moments);
      result.alternatives.push_back(alternative);
    }
  }
}

std::vector<EvidenceTerm> verificationEvidence(const VerificationSignals& s) {
  std::vector<EvidenceTerm> terms;
  const auto add = [&](const char* signal, double log_odds, const std::string& reason) {
    terms.push_back({signal, log_odds, log_odds < 0.0 ? reason : std::string()});
  };
  if (!std::isnan(s.rival_ratio)) {
    std::ostringstream reason;
    reason << std::fixed << std::setprecision(0) << "ambiguous: a pose " << s.rival_rotation_deg << " deg ("
           << std::setprecision(2) << s.rival_displacement << " m) away scores " << s.rival_ratio
           << " of the best";
    add("rival_ratio", std::min(kRivalMost, kRivalSlope * (kRivalEvenOdds - s.rival_ratio)), reason.str());
  }
  if (!std::isnan(s.chance_significance)) {
    std::ostringstream reason;
    reason << std::fixed << std::setprecision(1) << "a consensus near chance: " << s.chance_inliers
           << " inliers expected from unrelated matches at this pose, and one as large among the hypotheses"
           << " tried " << std::setprecision(2) << std::exp(-s.chance_significance) << " times";
    add("chance_significance", std::min(0.0, s.chance_significance - kChanceFree), reason.str());
  }
  if (!std::isnan(s.free_space_violation)) {
    add("free_space_violation",
        std::min(1.0, 1.0 - kFreeSpaceSlope * (s.free_space_violation - kFreeSpaceAllowed)),
        percent(s.free_space_violation) +
            " of the aligned points lie in space the other scan saw as empty (a " + "right pose: below " +
            percent(kFreeSpaceAllowed) + ")");
  }
  if (!std::isnan(s.aligned_overlap)) {
    add("aligned_overlap", std::min(1.0, kOverlapSlope * (s.aligned_overlap - kOverlapEvenOdds)),
        "aligned overlap " + percent(s.aligned_overlap) + " below " + percent(kOverlapEvenOdds));
  }
  if (!std::isnan(s.seen_on_surface)) {
    add("seen_on_surface", std::min(1.0, kSeenSlope * (s.seen_on_surface - kSeenEvenOdds)),
        "of the aligned source where the target looked, only " + percent(s.seen_on_surface) +
            " lies on its surfaces (below " + percent(kSeenEvenOdds) + ")");
  }
  if (!std::isnan(s.surface_agreement)) {
    add("surface_agreement", std::min(0.0, kAgreementSlope * (s.surface_agreement - kAgreementFree)),
        "of the aligned source on the target's surfaces, only " + percent(s.surface_agreement) +
            " lies along them (normals within 30 deg; chance: 13 %)");
  }
  if (!std::isnan(s.inlier_planarity) && !std::isnan(s.scene_planarity)) {
    const double flatter = relativePlanarity(s);
    std::ostringstream reason;
    reason << std::setprecision(2) << "the inliers lie near one plane (planarity " << s.inlier_planarity
           << ", the matched points' " << s.scene_planarity
           << "): a pose turned or slid along it explains them as well";
    add("inlier_planarity", -kPlanaritySlope * std::max(0.0, std::log(kPlanarityFree / flatter)),
        reason.str());
  }
  const bool settled_on_target = s.fine_alignment_converged == 1.0 && s.aligned_overlap >= kSettledOverlap &&
                                 s.fine_alignment_support > 0.0;
  if (!std::isnan(s.fine_alignment_move) && !(s.fine_alignment_support >= kMoveFollowed) &&
      !settled_on_target) {
    std::ostringstream reason;
    reason << std::fixed << std::setprecision(1) << "the fine alignment on the clouds moved the pose "
           << s.fine_alignment_move << " tau (RMS; a right pose: below " << kMoveFree << ")";
    add("fine_alignment_move", -kMoveSlope * std::max(0.0, s.fine_alignment_move - kMoveFree), reason.str());
  }
  if (s.fine_alignment_converged == 0.0)
    add("fine_alignment_converged", -kUnsettled,
        "the fine alignment was still sliding when its steps ran out");
  return terms;
}

double confidenceOf(const std::vector<EvidenceTerm>& terms) {
  double log_odds = 0.0;
  for (const EvidenceTerm& t : terms) log_odds += t.log_odds;
  return 1.0 / (1.0 + std::exp(-log_odds));
}

void decideVerification(const VerificationParams& params, MacResult& result) {
  if (!result.success && result.status != RegistrationStatus::kUnverified) return;
  std::vector<EvidenceTerm> terms = verificationEvidence(result.verification);
  result.confidence = confidenceOf(terms);
  result.evidence = terms;
  if (!std::isnan(result.verification.scene_planarity) &&
      relativePlanarity(result.verification) < kPlanarityFree) {
    std::ostringstream warning;
    warning << "the inliers lie close to one plane (planarity " << std::setprecision(2)
            << result.verification.inlier_planarity << ", the matched points' "
            << result.verification.scene_planarity
            << "): rotations and slides along it are weakly constrained by the correspondences";
    result.warnings.push_back(warning.str());
  }
  if (result.confidence >= params.min_confidence) {
    result.success = true;
    result.status = RegistrationStatus::kSuccess;
    result.message = successSummary(result);
    return;
  }
  result.success = false;
  result.status = RegistrationStatus::kUnverified;
  // The strongest objections first.
  std::stable_sort(terms.begin(), terms.end(),
                   [](const EvidenceTerm& a, const EvidenceTerm& b) { return a.log_odds < b.log_odds; });
  std::ostringstream text;
  text << "confidence " << std::fixed << std::setprecision(2) << result.confidence << " below "
       << params.min_confidence << " (verification.min_confidence)";
  const char* separator = ": ";
  for (const EvidenceTerm& t : terms) {
    if (t.reason.empty()) continue;
    text << separator << t.reason;
    separator = "; ";
  }
  result.message = text.str();
}

namespace {

// `into`'s fields that `from` measured, replaced by `from`'s.
void takeMeasured(const VerificationSignals& from, VerificationSignals& into) {
  const auto take = [](double measured, double& field) {
    if (!std::isnan(measured)) field = measured;
  };
  take(from.rival_ratio, into.rival_ratio);
  take(from.rival_rotation_deg, into.rival_rotation_deg);
  take(from.rival_displacement, into.rival_displacement);
  take(from.chance_inliers, into.chance_inliers);
  take(from.chance_significance, into.chance_significance);
  take(from.inlier_planarity, into.inlier_planarity);
  take(from.inlier_linearity, into.inlier_linearity);
  take(from.scene_planarity, into.scene_planarity);
  take(from.fine_alignment_move, into.fine_alignment_move);
  take(from.fine_alignment_converged, into.fine_alignment_converged);
  take(from.aligned_overlap, into.aligned_overlap);
  take(from.seen_on_surface, into.seen_on_surface);
  take(from.surface_agreement, into.surface_agreement);
  take(from.free_space_violation, into.free_space_violation);
}

}  // namespace

void alignFinely(const PoseWitness& witness, double tau, MacResult& result) {
  const auto start = std::chrono::steady_clock::now();
  if (const std::optional<FineAlignment> fine = witness.refine(result.T_target_source)) {
    result.fine_alignment = *fine;
    if (fine->iterations > 0 && tau > 0.0) {
      result.verification.fine_alignment_move = fine->displacement / tau;
      result.verification.fine_alignment_converged = fine->converged ? 1.0 : 0.0;
    }
  }
  result.times.fine_alignment_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

namespace {

// The correspondences' inliers at `to` per inlier at the reported pose (counted by the refinement).
double inlierCountRatio(const HypothesisEvaluator& evaluator, std::size_t inliers,
                        const Eigen::Isometry3d& to) {
  return inliers > 0 ? double(evaluator.score(to).inliers) / double(inliers) : kNotMeasured;
}

// Of two judgements by the clouds, each signal at its less favourable value (NaN where neither measured
// it); the fields a witness does not measure are taken from `a`.
VerificationSignals lessFavourable(const VerificationSignals& a, const VerificationSignals& b) {
  const auto pick = [](double x, double y, bool higher_is_better) {
    if (std::isnan(x)) return y;
    if (std::isnan(y)) return x;
    return higher_is_better ? std::min(x, y) : std::max(x, y);
  };
  VerificationSignals worse = a;
  worse.aligned_overlap = pick(a.aligned_overlap, b.aligned_overlap, true);
  worse.seen_on_surface = pick(a.seen_on_surface, b.seen_on_surface, true);
  worse.surface_agreement = pick(a.surface_agreement, b.surface_agreement, true);
  worse.free_space_violation = pick(a.free_space_violation, b.free_space_violation, false);
  return worse;
}

}  // namespace

void hearWitness(const PoseWitness& witness, MacResult& result) {
  VerificationSignals heard = witness.judge(result.T_target_source);
  // A fine alignment that only polished the pose (a move within the move term's free band) leaves one
  // pose judged twice: the least-squares fit can draw points out of another scan's free space or onto its
  // surfaces at a wrong pose as well (turned rooms refused at the pose the correspondences gave were
  // accepted at their polish), so a contradiction seen at either counts. A fine alignment that moved the
  // pose further reports another pose than the one the correspondences gave, coarse where the clouds are
  // sparse: the clouds judge the pose reported, and the move counts against it. Only the surfaces' agreement
  // is never taken from the fine pose alone: a point-to-plane fit turns surfaces along each other wherever it
  // ends (a kitchen corner turned 92 degrees into a street), so there it is no evidence of its own
  // (doc/decisions/judging-the-fine-pose.md).
  const FineAlignment& fine = result.fine_alignment;
  if (fine.ran && fine.iterations > 0) {
    const VerificationSignals at_fine = witness.judge(fine.T_target_source);
    const VerificationSignals worse = lessFavourable(heard, at_fine);
    if (result.verification.fine_alignment_move > kMoveFree) {
      heard = at_fine;
      heard.surface_agreement = worse.surface_agreement;
    } else {
      heard = worse;
    }
  }
  takeMeasured(heard, result.verification);
  for (std::string& warning : witness.warnings()) result.warnings.push_back(std::move(warning));
}

void verifyRegistration(const CorrespondenceSet& c, const std::vector<ScoredHypothesis>& hypotheses,
                        const HypothesisEvaluator& evaluator, const MacParams& params, const StopFlag* stop,
                        const PoseWitness* witness, MacResult& result) {
  if (!params.verification.enabled || !result.success) return;
  const auto start = std::chrono::steady_clock::now();
  measureCorrespondenceSignals(c, hypotheses, evaluator, params, stop, result);
  // A witness reads no stop flag: it is not heard once a stop came, and a stop during it still wins.
  if (witness != nullptr && params.verification.fine_alignment && !stopRequested(stop))
    alignFinely(*witness, params.evaluation.inlier_threshold, result);
  if (result.fine_alignment.ran && result.fine_alignment.iterations > 0)
    result.verification.fine_alignment_support =
        inlierCountRatio(evaluator, result.counters.inliers, result.fine_alignment.T_target_source);
  if (witness != nullptr && !stopRequested(stop)) hearWitness(*witness, result);
  if (stopRequested(stop)) {
    result.success = false;
    result.status = RegistrationStatus::kCancelled;
    result.message = "cancelled at the verification";
    return;
  }
  // One decision, on the evidence of the correspondences and of the witness together.
  decideVerification(params.verification, result);
  // The estimate, verified or not, is the clouds' fit: the pose the correspondences gave stays beside it.
  if (result.fine_alignment.ran && result.fine_alignment.iterations > 0)
    result.T_target_source = result.fine_alignment.T_target_source;
  if (result.success && !withinTilt(result.T_target_source, params.evaluation)) {
    // The prior binds the pose reported too, and the fine alignment may carry a pose across it.
    std::ostringstream text;
    text << "the fine alignment tilted the pose " << std::fixed << std::setprecision(1)
         << tiltDeg(result.T_target_source) << " deg, beyond evaluation.max_tilt_deg ("
         << params.evaluation.max_tilt_deg << ")";
    result.success = false;
    result.status = RegistrationStatus::kUnverified;
    result.message = text.str();
  }
  result.times.verification_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace mac_registration
