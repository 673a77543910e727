#pragma once

#include <cstddef>
#include <limits>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

// When a registration counts as recalled (the papers' registration recall).
struct SuccessCriterion {
  double max_rotation_deg = 15.0;  // [deg] 3DMatch: 15; KITTI-like lidar: 5
  double max_translation = 0.30;   // [m] 3DMatch: 0.3; KITTI-like lidar: 0.6
  bool accepts(double rotation_error_deg, double translation_error) const {
    return rotation_error_deg <= max_rotation_deg && translation_error <= max_translation;
  }
};

// What one method made of one pair.
struct MethodOutcome {
  std::string method;       // "MAC", "RANSAC"
  bool registered = false;  // the method reported success
  std::string status;       // its status, e.g. "success", "too few inliers"
  double rotation_error_deg = std::numeric_limits<double>::quiet_NaN();  // NaN without a transform
  double translation_error = std::numeric_limits<double>::quiet_NaN();   // [m]
  bool within_criterion = false;  // its transform is within the criterion, whether reported or not
  bool recalled = false;          // registered and within the criterion
  // The verification's confidence in its pose (MAC's result; NaN for the baselines): what a run at another
  // verification.min_confidence would have compared with it.
  double confidence = std::numeric_limits<double>::quiet_NaN();
  std::size_t inliers = 0;  // of its own transform, at its own threshold
  StageTimes times;         // per stage for MAC, total only for the baselines
  // A peer with its own front end (Open3D on the clouds) sets its stages here; unset: the pair's, ours.
  std::optional<StageTimes> front_end;
  // [MiB] peak resident memory of the process while the method ran on this pair (front end included);
  // NaN when not measured (RANSAC shares MAC's process after MAC's peak was taken).
  double peak_mb = std::numeric_limits<double>::quiet_NaN();
};

struct PairOutcome {
  std::string name, subset, scene;
  std::string error;  // set when the pair could not be run (e.g. unreadable cloud): every method missed it
  std::size_t correspondences = 0;
  // Share of the correspondences within tau of their target under the ground truth.
  double inlier_ratio = 0.0;
  StageTimes front_end;  // ours: its front-end stages, all 0 for correspondence sets
  std::size_t source_points = 0, target_points = 0;  // of the clouds as read (0 for correspondence sets)
  std::vector<MethodOutcome> methods;                // same methods, same order, for every pair that ran

  // The front end `m` ran after: its own, else ours.
  const StageTimes& frontEndOf(const MethodOutcome& m) const {
    return m.front_end ? *m.front_end : front_end;
  }
};

// The stages of a registration from clouds in, in the order of the tables: the front end's, then the
// core's (the baselines report their total alone, under "other").
struct StageShare {
  const char* name;  // column name, e.g. "fpfh"
  double ms = 0.0;
  double percent = 0.0;  // of the total it was divided by
};

// The median of `values`, 0 for none.
double median(std::vector<double> values);

// Each stage's time and its share of `total_ms` (front end + method) [%]; the shares of a run whose
// stages cover its whole time add up to 100, and a last entry "other" holds the untimed rest (the
// baselines' whole method time), never negative.
std::vector<StageShare> stageShares(const StageTimes& front_end, const StageTimes& method, double total_ms);

// The method's outcome for a pair, after the criterion: within_criterion = the criterion accepts its errors,
// recalled = registered && within_criterion.
MethodOutcome judge(MethodOutcome outcome, const SuccessCriterion& criterion);

// One line of the paper-style table: a subset (or "all") and a method.
struct SummaryRow {
  std::string subset, method;
  std::size_t pairs = 0;  // of the subset, including pairs that could not be run
  std::size_t recalled = 0;
  double recall = 0.0;                                                        // recalled / pairs
  double mean_rotation_error_deg = std::numeric_limits<double>::quiet_NaN();  // over recalled pairs
  double mean_translation_error = std::numeric_limits<double>::quiet_NaN();   // [m], over recalled pairs
  double mean_inlier_ratio = 0.0;  // of the correspondences, over the pairs that ran
  StageTimes median_front_end;     // its front-end stages, stage by stage, over the pairs that ran
  double median_front_end_total_ms = 0.0;
  StageTimes median_times;       // stage by stage, over the pairs that ran
  double median_total_ms = 0.0;  // front end + method, per pair
  double median_peak_mb = std::numeric_limits<double>::quiet_NaN();  // over the pairs that measured it
};

// Rows per subset in order of first appearance, then "all" when there is more than one subset; within
// each, the methods in the order of the first pair that ran.
std::vector<SummaryRow> summarize(const std::vector<PairOutcome>& outcomes);

void printSummary(std::ostream& out, const std::vector<SummaryRow>& rows, const SuccessCriterion& criterion);

// Ours against a peer pair by pair (pairs both ran): recall, RE/TE, time per stage, total and peak memory
// of each, the ratio ours/peer of the total time and of the peak memory, and the median ratios. Prints
// nothing when either method is absent.
void printPeerComparison(std::ostream& out, const std::vector<PairOutcome>& outcomes, const std::string& ours,
                         const std::string& peer);

// One row per pair and method (a pair that could not be run: one row with its error); what
// tools/plot_benchmark.py reads.
void writeOutcomesCsv(std::ostream& out, const std::vector<PairOutcome>& outcomes);

// One progress line of pair k of `count`: its correspondences, inlier ratio, front-end time and each
// method's outcome.
void printPairProgress(std::ostream& out, std::size_t k, std::size_t count, const PairOutcome& r);

}  // namespace mac_registration
