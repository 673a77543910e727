#pragma once

// The labelled evaluation of the verification: cases whose right answer is known (pairs with ground
// truth) or known not to exist (pairs that do not overlap, unrelated scenes, correspondence sets without
// a single inlier), each registered once; how often `success` is right, as a function of
// verification.min_confidence.

#include <cstdint>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "benchmark_runner.hpp"
#include "mac_registration/core/mac_result.hpp"
#include "synthetic.hpp"

namespace mac_registration {

struct VerificationCase {
  std::string name, subset;
  std::string kind;  // "pair", or how the case was made from one: "no inliers", "shuffled", synthetic ...
  // A right pose exists in the correspondences and is known: a positive. Otherwise a negative, where an
  // accept is a false accept unless the pose happens to be right (possible when the truth is known but the
  // correspondences hold none of it: the derived negatives).
  bool answerable = false;
  bool has_truth = false;   // the ground truth is known, so the pose can be judged
  bool registered = false;  // a transform came out (success or kUnverified), before the threshold
  bool correct = false;     // registered, has_truth and within the criterion
  double rotation_error_deg = std::numeric_limits<double>::quiet_NaN();
  double translation_error = std::numeric_limits<double>::quiet_NaN();  // [m]
  // Of the correspondences' pose, before a fine alignment (the same as above where none ran).
  double global_rotation_error_deg = std::numeric_limits<double>::quiet_NaN();
  double global_translation_error = std::numeric_limits<double>::quiet_NaN();  // [m]
  // The clouds' fine alignment started at the ground truth (pairs of clouds with one): how far it moves the
  // truth, and how far from the reported pose it ends.
  double truth_fit_moves_deg = std::numeric_limits<double>::quiet_NaN();
  double truth_fit_moves_m = std::numeric_limits<double>::quiet_NaN();
  double truth_fit_to_reported_deg = std::numeric_limits<double>::quiet_NaN();
  double truth_fit_to_reported_m = std::numeric_limits<double>::quiet_NaN();
  std::size_t correspondences = 0;
  double inlier_ratio = 0.0;  // under the ground truth, at tau (0 without one)
  double front_end_ms = 0.0;
  std::string error;  // the case could not be run: counted as not registered
  MacResult result;
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
};

// Turns a result into a case: registered, errors against the truth, correct. The errors are those of the
// reported pose (the fine alignment's, where one ran), whatever the decision: a threshold swept over the
// confidence accepts that pose.
VerificationCase judgeCase(VerificationCase c, const MacResult& result, const Eigen::Isometry3d& truth,
                           const SuccessCriterion& criterion);

// The pair as it is (kind "pair"); with `derived`, for a pair with ground truth also two negatives made
// from its correspondences between the same clouds: "no inliers" (every correspondence within 3 tau of
// its target under the ground truth removed) and "shuffled" (the targets permuted among the sources).
std::vector<VerificationCase> runVerificationPair(const BenchmarkPair& pair,
                                                  const BenchmarkSettings& settings, bool derived);

// Synthetic cases on the mesh: for each size, the inlier ratios as positives ("synthetic"), and as
// negatives a set of uniform outliers ("synthetic 0 %") and one whose targets lie on the surface of the
// same object seen at an unrelated pose, paired at random ("synthetic unrelated").
std::vector<VerificationCase> runSyntheticVerification(const TriangleMesh& mesh,
                                                       const std::vector<int>& sizes,
                                                       const std::vector<double>& ratios, double noise,
                                                       int seeds, const MacParams& params);

// Success as a function of min_confidence: a case is accepted at threshold c when it registered with a
// confidence >= c.
struct OperatingPoint {
  double min_confidence = 0.0;
  std::size_t positives = 0;           // cases with a known right answer
  std::size_t true_accepts = 0;        // positives accepted with a right pose
  std::size_t false_accepts = 0;       // accepted with a wrong pose (of a positive, or of a negative)
  std::size_t wrong_poses = 0;         // positives that registered to a wrong pose
  std::size_t wrong_accepted = 0;      // of them, accepted
  std::size_t negatives = 0;           // cases without a right answer
  std::size_t negatives_accepted = 0;  // with a wrong pose (a right one by chance is no harm)
  double precision() const {
    const std::size_t accepts = true_accepts + false_accepts;
    return accepts ? double(true_accepts) / double(accepts) : 1.0;
  }
  double recall() const { return positives ? double(true_accepts) / double(positives) : 0.0; }
  double falseAcceptRate() const { return negatives ? double(negatives_accepted) / double(negatives) : 0.0; }
};

OperatingPoint operatingPoint(const std::vector<VerificationCase>& cases, double min_confidence);

// One line per threshold (precision, recall, false accepts), `current` marked.
void printOperatingPoints(std::ostream& out, const std::vector<VerificationCase>& cases,
                          const std::vector<double>& thresholds, double current);

// At one threshold, per kind of case (pairs, each kind of negative): how many, how many registered, how
// many accepted with a right and with a wrong pose.
void printCasesByKind(std::ostream& out, const std::vector<VerificationCase>& cases, double min_confidence);

// One row per case: its labels, outcome, confidence and every signal.
void writeVerificationCsv(std::ostream& out, const std::vector<VerificationCase>& cases);

// One progress line of a case: its kind, outcome, confidence, errors against the truth and times.
void printVerificationCase(std::ostream& out, const VerificationCase& c);

}  // namespace mac_registration
