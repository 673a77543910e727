#include "verification_eval.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"

namespace mac_registration {
namespace {

double inlierShare(const CorrespondenceSet& c, const Eigen::Isometry3d& T, double threshold) {
  if (c.size() == 0) return 0.0;
  std::size_t inliers = 0;
  for (Eigen::Index k = 0; k < c.source_points.cols(); ++k)
    inliers += (T * c.source_points.col(k) - c.target_points.col(k)).norm() < threshold;
  return double(inliers) / double(c.size());
}

CorrespondenceSet keepColumns(const CorrespondenceSet& c, const std::vector<Eigen::Index>& columns) {
  CorrespondenceSet kept;
  kept.source_points.resize(3, Eigen::Index(columns.size()));
  kept.target_points.resize(3, Eigen::Index(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    kept.source_points.col(Eigen::Index(k)) = c.source_points.col(columns[k]);
    kept.target_points.col(Eigen::Index(k)) = c.target_points.col(columns[k]);
  }
  return kept;
}

// Every correspondence that is anywhere near right under the truth removed: what a front end returns
// when nothing of the target is in the source.
CorrespondenceSet withoutNearInliers(const CorrespondenceSet& c, const Eigen::Isometry3d& truth,
                                     double reach) {
  std::vector<Eigen::Index> far;
  for (Eigen::Index k = 0; k < c.source_points.cols(); ++k) {
    if ((truth * c.source_points.col(k) - c.target_points.col(k)).norm() >= reach) far.push_back(k);
  }
  return keepColumns(c, far);
}

// The targets permuted among the sources (a fixed seed): the same two point distributions, no
// correspondence left.
CorrespondenceSet shuffledTargets(const CorrespondenceSet& c, std::uint32_t seed) {
  std::vector<Eigen::Index> order(c.size());
  std::iota(order.begin(), order.end(), Eigen::Index(0));
  std::mt19937 rng(seed);
  std::shuffle(order.begin(), order.end(), rng);
  CorrespondenceSet shuffled;
  shuffled.source_points = c.source_points;
  shuffled.target_points.resize(3, c.target_points.cols());
  for (std::size_t k = 0; k < order.size(); ++k)
    shuffled.target_points.col(Eigen::Index(k)) = c.target_points.col(order[k]);
  return shuffled;
}

std::string percent(double share) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << 100.0 * share << " %";
  return text.str();
}

}  // namespace

VerificationCase judgeCase(VerificationCase c, const MacResult& result, const Eigen::Isometry3d& truth,
                           const SuccessCriterion& criterion) {
  c.result = result;
  c.truth = truth;
  c.registered = result.success || result.status == RegistrationStatus::kUnverified;
  if (c.registered && c.has_truth) {
    // T_target_source is the fine alignment's pose where one ran; its start is the correspondences' pose.
    const FineAlignment& fine = result.fine_alignment;
    const Eigen::Isometry3d& global = fine.ran && fine.iterations > 0 ? fine.start : result.T_target_source;
    c.rotation_error_deg = rotationErrorDeg(result.T_target_source, truth);
    c.translation_error = translationError(result.T_target_source, truth);
    c.global_rotation_error_deg = rotationErrorDeg(global, truth);
    c.global_translation_error = translationError(global, truth);
    c.correct = criterion.accepts(c.rotation_error_deg, c.translation_error);
  }
  return c;
}

namespace {

// Where the clouds' own fit lies near the ground truth: the witness's fine alignment started at the truth,
// how far it moves the truth and how far it ends from the pose reported. A wrong pose that the fit from
// the truth lands on is one the clouds cannot tell from the truth.
void fitFromTruth(const PoseWitness& witness, const Eigen::Isometry3d& truth, VerificationCase& c) {
  const std::optional<FineAlignment> fine = witness.refine(truth);
  if (!fine || fine->iterations == 0) return;
  const Eigen::Isometry3d& pose = c.result.T_target_source;
  c.truth_fit_moves_deg = rotationErrorDeg(fine->T_target_source, truth);
  c.truth_fit_moves_m = translationError(fine->T_target_source, truth);
  c.truth_fit_to_reported_deg = rotationErrorDeg(fine->T_target_source, pose);
  c.truth_fit_to_reported_m = translationError(fine->T_target_source, pose);
}

}  // namespace

std::vector<VerificationCase> runVerificationPair(const BenchmarkPair& pair,
                                                  const BenchmarkSettings& settings, bool derived) {
  VerificationCase base;
  base.name = pair.name;
  base.subset = pair.subset;
  base.kind = "pair";
  base.has_truth = base.answerable = pair.has_ground_truth;
  PreparedPair prepared;
  try {
    prepared = preparePair(pair, settings);
  } catch (const std::exception& e) {
    base.error = e.what();
    return {base};
  }
  const double tau = prepared.mac.evaluation.inlier_threshold;
  base.front_end_ms = prepared.front_end.frontEndMs();
  std::vector<VerificationCase> cases;
  const auto run = [&](VerificationCase c, const CorrespondenceSet& set) {
    c.correspondences = set.size();
    c.inlier_ratio = c.has_truth ? inlierShare(set, pair.T_target_source_gt, tau) : 0.0;
    cases.push_back(judgeCase(c, prepared.registerSet(set), pair.T_target_source_gt, settings.criterion));
  };
  run(base, prepared.correspondences);
  if (pair.has_ground_truth && prepared.cloud_witness && hasEstimate(cases.back().result))
    fitFromTruth(*prepared.cloud_witness(), pair.T_target_source_gt, cases.back());
  if (derived && pair.has_ground_truth) {
    VerificationCase negative = base;
    negative.answerable = false;
    negative.front_end_ms = 0.0;
    negative.kind = "no inliers";
    run(negative, withoutNearInliers(prepared.correspondences, pair.T_target_source_gt, 3.0 * tau));
    negative.kind = "shuffled";
    run(negative, shuffledTargets(prepared.correspondences, 7));
  }
  return cases;
}

std::vector<VerificationCase> runSyntheticVerification(const TriangleMesh& mesh,
                                                       const std::vector<int>& sizes,
                                                       const std::vector<double>& ratios, double noise,
                                                       int seeds, const MacParams& params) {
  std::vector<VerificationCase> cases;
  SuccessCriterion criterion;  // the 3 m object: 15 deg, 30 cm as for rooms
  for (int n : sizes) {
    for (int seed = 1; seed <= seeds; ++seed) {
      SyntheticSpec spec;
      spec.correspondences = n;
      spec.noise_sigma = noise;
      spec.object_size = 3.0;
      spec.seed = std::uint32_t(seed);
      const auto add = [&](const std::string& kind, double ratio, const CorrespondenceSet& set, bool truth,
                           const Eigen::Isometry3d& T) {
        VerificationCase c;
        std::ostringstream name;
        name << "synthetic N=" << n << " " << percent(ratio) << " seed " << seed;
        c.name = name.str();
        c.subset = kind;
        c.kind = kind;
        c.has_truth = c.answerable = truth;
        c.correspondences = set.size();
        c.inlier_ratio = ratio;
        cases.push_back(judgeCase(c, registerCorrespondences(set, params), T, criterion));
      };
      for (double ratio : ratios) {
        spec.inlier_ratio = ratio;
        const SyntheticProblem problem = makeSyntheticProblem(mesh, spec);
        add("synthetic", ratio, problem.correspondences, true, problem.T_target_source);
      }
      spec.inlier_ratio = 0.0;
      const SyntheticProblem outliers = makeSyntheticProblem(mesh, spec);
      add("synthetic 0 %", 0.0, outliers.correspondences, false, Eigen::Isometry3d::Identity());
      // Sources of one draw, targets of another: both on the object's surface, nothing corresponds.
      spec.inlier_ratio = 1.0;
      SyntheticProblem first = makeSyntheticProblem(mesh, spec);
      spec.seed = std::uint32_t(seed + 1000);
      const SyntheticProblem second = makeSyntheticProblem(mesh, spec);
      first.correspondences.target_points = second.correspondences.target_points;
      add("synthetic unrelated", 0.0, first.correspondences, false, Eigen::Isometry3d::Identity());
    }
  }
  return cases;
}

OperatingPoint operatingPoint(const std::vector<VerificationCase>& cases, double min_confidence) {
  OperatingPoint p;
  p.min_confidence = min_confidence;
  for (const VerificationCase& c : cases) {
    const bool accepted = c.registered && c.result.confidence >= min_confidence;
    if (c.answerable) {
      ++p.positives;
      if (c.registered && !c.correct) {
        ++p.wrong_poses;
        p.wrong_accepted += accepted;
      }
      p.true_accepts += accepted && c.correct;
    } else {
      ++p.negatives;
      p.negatives_accepted += accepted && !c.correct;
    }
    p.false_accepts += accepted && !c.correct;
  }
  return p;
}

void printOperatingPoints(std::ostream& out, const std::vector<VerificationCase>& cases,
                          const std::vector<double>& thresholds, double current) {
  out << "| min_confidence | precision | recall | false accepts | wrong poses accepted | negatives accepted "
         "|\n"
      << "|---|---|---|---|---|---|\n";
  for (double t : thresholds) {
    const OperatingPoint p = operatingPoint(cases, t);
    out << "| " << std::setprecision(2) << t << (std::abs(t - current) < 1e-9 ? " (preset)" : "") << " | "
        << percent(p.precision()) << " | " << percent(p.recall()) << " (" << p.true_accepts << "/"
        << p.positives << ") | " << p.false_accepts << " | " << p.wrong_accepted << "/" << p.wrong_poses
        << " | " << p.negatives_accepted << "/" << p.negatives << " (" << percent(p.falseAcceptRate())
        << ") |\n";
  }
}

void printCasesByKind(std::ostream& out, const std::vector<VerificationCase>& cases, double min_confidence) {
  std::vector<std::string> kinds;
  for (const VerificationCase& c : cases) {
    const std::string kind = c.subset + (c.kind == "pair" ? "" : " (" + c.kind + ")");
    if (std::find(kinds.begin(), kinds.end(), kind) == kinds.end()) kinds.push_back(kind);
  }
  out << "| cases | answer | count | registered | accepted, right pose | accepted, wrong pose |\n"
      << "|---|---|---|---|---|---|\n";
  for (const std::string& kind : kinds) {
    std::size_t count = 0, registered = 0, right = 0, wrong = 0;
    bool answerable = false;
    for (const VerificationCase& c : cases) {
      if (c.subset + (c.kind == "pair" ? "" : " (" + c.kind + ")") != kind) continue;
      ++count;
      answerable |= c.answerable;
      registered += c.registered;
      const bool accepted = c.registered && c.result.confidence >= min_confidence;
      right += accepted && c.correct;
      wrong += accepted && !c.correct;
    }
    out << "| " << kind << " | " << (answerable ? "known" : "none") << " | " << count << " | " << registered
        << " | " << right << " | " << wrong << " |\n";
  }
}

namespace {

// The evidence terms as "signal:log-odds" separated by spaces.
std::string evidenceText(const std::vector<EvidenceTerm>& terms) {
  std::ostringstream text;
  text << std::setprecision(6);
  for (std::size_t k = 0; k < terms.size(); ++k)
    text << (k ? " " : "") << terms[k].signal << ":" << terms[k].log_odds;
  return text.str();
}

}  // namespace

void writeVerificationCsv(std::ostream& out, const std::vector<VerificationCase>& cases) {
  out << "name,subset,kind,answerable,has_truth,registered,correct,success,status,confidence,re_deg,te_m,"
         "correspondences,inlier_ratio,inliers,rival_ratio,rival_rotation_deg,rival_displacement_m,"
         "aligned_overlap,seen_on_surface,free_space_violation,surface_agreement,chance_inliers,"
         "chance_significance,inlier_planarity,inlier_linearity,scene_planarity,alternatives,alternative_"
         "score_ratio,"
         "alternative_rotation_deg,alternative_re_deg,alternative_te_m,global_re_deg,global_te_m,"
         "fine_alignment_move,fine_alignment_converged,fine_alignment_support,covariance_translation_m,"
         "covariance_rotation_deg,"
         "fine_alignment_rotation_deg,fine_alignment_fitness,"
         "fine_alignment_rmse,"
         "fine_alignment_iterations,truth_fit_moves_deg,truth_fit_moves_m,truth_fit_to_reported_deg,"
         "truth_fit_to_reported_m,tilt_deg,global_tilt_deg,truth_tilt_deg,front_end_ms,core_ms,verification_"
         "ms,fine_alignment_ms,evidence,message\n";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const VerificationCase& c : cases) {
    const MacResult& r = c.result;
    const VerificationSignals& s = r.verification;
    const FineAlignment& f = r.fine_alignment;
    const bool alternative = !r.alternatives.empty();
    const PoseAlternative a = alternative ? r.alternatives.front() : PoseAlternative{};
    std::string message = c.error.empty() ? r.message : c.error;
    std::replace(message.begin(), message.end(), '"', '\'');
    out << "\"" << c.name << "\"," << c.subset << "," << c.kind << "," << c.answerable << "," << c.has_truth
        << "," << c.registered << "," << c.correct << "," << r.success << "," << toString(r.status) << ","
        << r.confidence << "," << c.rotation_error_deg << "," << c.translation_error << ","
        << c.correspondences << "," << c.inlier_ratio << "," << r.counters.inliers << "," << s.rival_ratio
        << "," << s.rival_rotation_deg << "," << s.rival_displacement << "," << s.aligned_overlap << ","
        << s.seen_on_surface << "," << s.free_space_violation << "," << s.surface_agreement << ","
        << s.chance_inliers << "," << s.chance_significance << "," << s.inlier_planarity << ","
        << s.inlier_linearity << "," << s.scene_planarity << "," << r.alternatives.size() << ","
        << (alternative ? a.score_ratio : nan) << "," << (alternative ? a.rotation_deg : nan) << ","
        << (alternative && c.has_truth ? rotationErrorDeg(a.T_target_source, c.truth) : nan) << ","
        << (alternative && c.has_truth ? translationError(a.T_target_source, c.truth) : nan) << ","
        << c.global_rotation_error_deg << "," << c.global_translation_error << "," << s.fine_alignment_move
        << "," << s.fine_alignment_converged << "," << s.fine_alignment_support << ","
        << (f.ran ? std::sqrt(f.covariance.block<3, 3>(0, 0).trace()) : nan) << ","
        << (f.ran ? std::sqrt(f.covariance.block<3, 3>(3, 3).trace()) * 180.0 / M_PI : nan) << ","
        << (f.ran ? f.rotation_deg : nan) << "," << (f.ran ? f.fitness : nan) << "," << (f.ran ? f.rmse : nan)
        << "," << f.iterations << "," << c.truth_fit_moves_deg << "," << c.truth_fit_moves_m << ","
        << c.truth_fit_to_reported_deg << "," << c.truth_fit_to_reported_m << ","
        << tiltDeg(r.T_target_source) << ","
        << tiltDeg(f.ran && f.iterations > 0 ? f.start : r.T_target_source) << ","
        << (c.has_truth ? tiltDeg(c.truth) : nan) << "," << c.front_end_ms << ","
        << r.times.total_ms - r.times.verification_ms << "," << r.times.verification_ms << ","
        << r.times.fine_alignment_ms << ",\"" << evidenceText(r.evidence) << "\",\"" << message << "\"\n";
  }
}

void printVerificationCase(std::ostream& out, const VerificationCase& c) {
  out << c.name << " [" << c.kind << (c.answerable ? "" : ", no answer") << "] ";
  if (!c.error.empty()) {
    out << "ERROR: " << c.error << std::endl;
    return;
  }
  const MacResult& r = c.result;
  out << std::fixed << std::setprecision(2) << (r.success ? "success" : toString(r.status)) << " conf "
      << r.confidence;
  if (c.registered && c.has_truth)
    out << std::setprecision(1) << " RE " << c.rotation_error_deg << " TE " << 100 * c.translation_error
        << "cm " << (c.correct ? "right" : "WRONG");
  out << std::setprecision(2) << " | " << r.message << " | verify " << r.times.verification_ms << "ms of "
      << r.times.total_ms << std::endl;
  out.unsetf(std::ios::fixed);
}

}  // namespace mac_registration
