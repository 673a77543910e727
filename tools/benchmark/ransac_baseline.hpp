#pragma once

#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

// The baseline MAC is compared with: RANSAC on the same putative correspondences, as PCL runs it in
// pcl::registration::CorrespondenceRejectorSampleConsensus (3-point samples, Umeyama/SVD hypotheses,
// inlier count, adaptive stop at 99 % confidence).
struct RansacParams {
  double inlier_threshold = 0.1;  // [m], > 0: as evaluation.inlier_threshold of MAC
  int max_iterations = 50000;     // [samples], >= 1. The MAC paper reports 50K, 1M and 4M.
  bool refine = true;             // PCL's re-estimation of the model on its inliers
  std::size_t min_inliers = 3;    // fewest inliers for a success, as evaluation.min_inliers
};

// The result in the core's form, so that tools handle both methods alike: success, status, message,
// T_target_source, inlier indices (into `correspondences`), counters.correspondences / dropped_non_finite /
// inliers and times.total_ms. Never throws. Deterministic (PCL's RANSAC seeds its generator).
MacResult registerCorrespondencesRansac(const CorrespondenceSet& correspondences, const RansacParams& params);

}  // namespace mac_registration
