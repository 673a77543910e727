#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
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

// A search structure over one set of descriptors (FLANN's single kd-tree), built on first use and then
// shared: a target that stays the same is indexed once for every source matched against it. Its searches
// only read it, so any number of matches may use one index at the same time; the first of them builds it
// while the others wait. The descriptors must not change while it lives.
class DescriptorIndex {
 public:
  explicit DescriptorIndex(FpfhCloud::ConstPtr descriptors);
  ~DescriptorIndex();
  DescriptorIndex(const DescriptorIndex&) = delete;
  DescriptorIndex& operator=(const DescriptorIndex&) = delete;

  const FpfhCloud::ConstPtr& descriptors() const { return descriptors_; }
  // Whether some match has built the tree already.
  bool built() const;

  struct Tree;  // defined where it is searched (feature_matching.cpp)
  // The tree, built by the first caller.
  const Tree& tree() const;

 private:
  FpfhCloud::ConstPtr descriptors_;
  mutable std::once_flag once_;
  mutable std::unique_ptr<const Tree> tree_;
  mutable std::atomic<bool> built_{false};
};

// Each source descriptor's nearest target descriptor (kd-tree search, exact when params.match_epsilon = 0,
// else within (1 + match_epsilon) of the nearest distance),
// optionally kept only when mutual (params.mutual_filter) and distinctive (params.ratio_test); then the
// params.max_correspondences closest, ascending by distance (ties by source index: deterministic).
std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats);

// The same on indices built before (either may be built or not yet): the target's tree is searched by
// every source descriptor, the source's only with params.mutual_filter, by the targets some source
// descriptor found nearest. The same matches as above, bit for bit.
std::vector<FeatureMatch> matchFeatures(const DescriptorIndex& source, const DescriptorIndex& target,
                                        const FeatureParams& params, MatchingStats& stats);

}  // namespace mac_registration
