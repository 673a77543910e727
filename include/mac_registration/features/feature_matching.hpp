#pragma once

#include <cstddef>
#include <vector>

#include "mac_registration/features/feature_params.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// A putative correspondence between descriptor `source` of the source set and
// descriptor `target` of the target set, and their Euclidean distance in descriptor space.
struct FeatureMatch {
  int source = 0;
  int target = 0;
  float distance = 0.0f;
};

struct MatchingStats {
  std::size_t rejected_mutual = 0;  // source's nearest target has another nearest source
  std::size_t rejected_ratio = 0;   // nearest / second nearest distance above the ratio
  std::size_t truncated = 0;        // beyond max_correspondences
};

// Each source descriptor's nearest target descriptor (kd-tree search, exact when params.match_epsilon = 0,
// else within (1 + match_epsilon) of the nearest distance),
// optionally kept only when mutual (params.mutual_filter) and distinctive (params.ratio_test); then the
// params.max_correspondences closest, ascending by distance (ties by source index: deterministic).
std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats);

}  // namespace mac_registration
