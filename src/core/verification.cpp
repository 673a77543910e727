#include "mac_registration/core/verification.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <sstream>

#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/refinement.hpp"

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
  const std::vector<double> best_residuals = evaluator.residuals(best);
  std::vector<RivalCandidate> rivals;
  for (const int h : order) {
    if (int(rivals.size()) >= kRivalsExamined || stopRequested(stop)) break;
    if (rmsDisplacement(hypotheses[h].T_target_source, best, moments) <= distinct) continue;
    const std::vector<double> residuals = evaluator.residuals(hypotheses[h].T_target_source);
    double exclusive = 0.0;
    for (std::size_t i = 0; i < residuals.size(); ++i) {
      if (!(best_residuals[i] < tau)) exclusive += closeness(residuals[i], tau, params.evaluation.metric);
    }
    rivals.push_back({h, exclusive});
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

  // The distinct rivals, refined, as alternatives a caller can disambiguate with other knowledge.
  result.alternatives.clear();
  std::vector<Eigen::Isometry3d> kept{best};
  const auto farFromKept = [&](const Eigen::Isometry3d& T) {
    return std::all_of(kept.begin(), kept.end(),
                       [&](const Eigen::Isometry3d& k) { return rmsDisplacement(T, k, moments) > distinct; });
  };
  for (const RivalCandidate& rival : rivals) {
    if (result.alternatives.size() >= params.verification.max_alternatives || stopRequested(stop)) break;
    const ScoredHypothesis& h = hypotheses[rival.hypothesis];
    if (!farFromKept(h.T_target_source)) continue;
    const RefinementOutcome refined =
        refineTransform(h.T_target_source, h.score, c, evaluator, params.evaluation, params.refinement, stop);
    if (!farFromKept(refined.T_target_source)) continue;  // it fell into a pose already listed
    kept.push_back(refined.T_target_source);
    PoseAlternative alternative;
    alternative.T_target_source = refined.T_target_source;
    alternative.score = refined.score.score;
    alternative.inliers = refined.score.inliers;
    alternative.score_ratio = result.score > 0.0 ? alternative.score / result.score : 0.0;
    alternative.rotation_deg = rotationErrorDeg(best, refined.T_target_source);
    alternative.displacement = rmsDisplacement(best, refined.T_target_source, moments);
    result.alternatives.push_back(alternative);
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

void verifyRegistration(const CorrespondenceSet& c, const std::vector<ScoredHypothesis>& hypotheses,
                        const HypothesisEvaluator& evaluator, const MacParams& params, const StopFlag* stop,
                        MacResult& result) {
  if (!params.verification.enabled || !result.success) return;
  const auto start = std::chrono::steady_clock::now();
  measureCorrespondenceSignals(c, hypotheses, evaluator, params, stop, result);
  if (stopRequested(stop)) {
    result.success = false;
    result.status = RegistrationStatus::kCancelled;
    result.message = "cancelled at the verification";
    return;
  }
  decideVerification(params.verification, result);
  result.times.verification_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace mac_registration
