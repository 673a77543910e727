// The MAC paper's table of a whole benchmark (registration recall, mean RE and TE over the recalled pairs,
// time per pair), and what the verification adds to it: the successes that are wrong, and how many would
// be at other thresholds. A result keeps its confidence whether or not it passed, so one run is
// re-thresholded at every verification.min_confidence instead of being run again for each.
#pragma once

#include <cstddef>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "benchmark_table.hpp"

namespace mac_registration {

// A wrong pose far off, not a near miss of the criterion: the errors a robot acting on it would notice.
struct GrossError {
  double min_rotation_deg = 30.0;  // [deg] beyond it, gross
  double min_translation = 1.0;    // [m]
  bool classifies(double rotation_error_deg, double translation_error) const {
    return rotation_error_deg > min_rotation_deg || translation_error > min_translation;
  }
};

// One method on one benchmark (scene empty: all of its scenes) or on one of its scenes.
struct PaperRow {
  std::string benchmark, scene;
  std::size_t scenes = 0;
  std::size_t pairs = 0;      // the benchmark's pairs, those that could not be run included (misses)
  std::size_t successes = 0;  // reported success
  std::size_t right = 0;      // successes within the criterion: the recalled pairs
  std::size_t wrong = 0;      // successes outside the criterion
  std::size_t gross = 0;      // wrong successes beyond the gross error
  // Poses within the criterion whether the verification passed them or not (success or unverified).
  std::size_t right_estimates = 0;
  double mean_rotation_error_deg = std::numeric_limits<double>::quiet_NaN();  // over the recalled pairs
  double mean_translation_error = std::numeric_limits<double>::quiet_NaN();   // [m], over the recalled pairs
  // Per pair that ran, front end + method [ms]; NaN when none ran.
  double mean_ms = std::numeric_limits<double>::quiet_NaN();
  double median_ms = std::numeric_limits<double>::quiet_NaN();
  double median_method_ms = std::numeric_limits<double>::quiet_NaN();  // the method alone

  double recall() const { return pairs ? double(right) / double(pairs) : 0.0; }
  double recallWithoutVerification() const { return pairs ? double(right_estimates) / double(pairs) : 0.0; }
  double falseAcceptRate() const { return successes ? double(wrong) / double(successes) : 0.0; }
};

// The method's outcome as a run at `min_confidence` would have reported it: a pose the verification judged
// (success or unverified) is accepted when its confidence is at least the threshold. Any other failure
// (no clique, too few inliers, the pair could not be run) is never accepted.
bool acceptedAt(const MethodOutcome& m, double min_confidence);

// `method` on each benchmark (subset) in order of first appearance, each followed, with `per_scene`, by
// one row per scene in order of first appearance.
std::vector<PaperRow> paperRows(const std::vector<PairOutcome>& outcomes, const std::string& method,
                                const GrossError& gross, bool per_scene);

// One benchmark's successes as they would have been at one verification.min_confidence.
struct ThresholdRow {
  std::string benchmark;
  double min_confidence = 0.0;
  std::size_t pairs = 0;
  std::size_t accepted = 0;  // would have been reported successes
  std::size_t right = 0, wrong = 0, gross = 0;
  double recall() const { return pairs ? double(right) / double(pairs) : 0.0; }
  double falseAcceptRate() const { return accepted ? double(wrong) / double(accepted) : 0.0; }
};

// For each benchmark in order of first appearance, one row per threshold in the given order.
std::vector<ThresholdRow> thresholdRows(const std::vector<PairOutcome>& outcomes, const std::string& method,
                                        const std::vector<double>& thresholds, const GrossError& gross);

// Both tables in Markdown: the paper's (recall with and without the verification, wrong successes) and the
// thresholds' (the run's own `current` marked).
void printPaperTable(std::ostream& out, const std::vector<PaperRow>& rows,
                     const std::vector<ThresholdRow>& thresholds, double current,
                     const SuccessCriterion& criterion, const GrossError& gross);

}  // namespace mac_registration
