#pragma once

#include <atomic>
#include <cstddef>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "mac_registration/config/feature_params.hpp"
#include "mac_registration/core/stop_flag.hpp"
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

// The search structures over one set of descriptors, each built on first use and then shared: a target that
// stays the same is prepared once for every source matched against it. Two structures, for the two
// searches: FLANN's single kd-tree (the approximate search, params.match_epsilon > 0) and the descriptors
// packed for the exact brute-force scan (params.match_epsilon = 0): tiles of kPackedLanes descriptors in
// ascending order of their norm, dimension-major within a tile, 64-byte aligned, the last tile padded
// with +inf. Searches only read them,
// so any number of matches may use one index at the same time; the first of them builds what it needs
// while the others wait. The descriptors must not change while it lives.
class DescriptorIndex {
 public:
  explicit DescriptorIndex(FpfhCloud::ConstPtr descriptors);
  ~DescriptorIndex();
  DescriptorIndex(const DescriptorIndex&) = delete;
  DescriptorIndex& operator=(const DescriptorIndex&) = delete;

  const FpfhCloud::ConstPtr& descriptors() const { return descriptors_; }
  // Whether some match has built either structure already.
  bool built() const;

  struct Tree;  // defined where it is searched (feature_matching.cpp)
  // The tree, built by the first caller.
  const Tree& tree() const;

  static constexpr int kPackedLanes = 16;  // descriptors a tile: two AVX2 registers of floats
  static constexpr int kDimensions = 33;   // FPFH histogram bins
  struct Packed {
    int count = 0;  // descriptors
    int tiles = 0;  // ceil(count / kPackedLanes)
    // tiles * kDimensions * kPackedLanes floats: bin d of descriptor tile * kPackedLanes + lane at
    // [(tile * kDimensions + d) * kPackedLanes + lane]
    std::unique_ptr<float[], void (*)(float*)> values{nullptr, nullptr};
    // tiles * kPackedLanes squared Euclidean norms (+inf in the padding), for the dot-product screening;
    // ascending
    std::unique_ptr<float[], void (*)(float*)> squared_norms{nullptr, nullptr};
    // The descriptor in each slot (tile * kPackedLanes + lane), -1 in the padding: slots hold the
    // descriptors by ascending norm (ties: ascending index), so that a search can skip the tiles whose
    // norms differ from the query's by more than the distance it has found, | |q| - |t| | <= |q - t|.
    std::vector<int> descriptor_of_slot;
    // Per tile, the smallest and the largest Euclidean norm of its descriptors (the padding left out).
    std::vector<double> tile_norm_low, tile_norm_high;
  };
  // The packed descriptors, packed by the first caller.
  const Packed& packed() const;

 private:
  FpfhCloud::ConstPtr descriptors_;
  mutable std::once_flag tree_once_, packed_once_;
  mutable std::unique_ptr<const Tree> tree_;
  mutable std::unique_ptr<const Packed> packed_;
  mutable std::atomic<bool> built_{false};
};

// One query's two nearest descriptors in a reference set. Distances are Euclidean; the second is infinite
// when the reference holds one descriptor.
struct NearestDescriptors {
  int nearest = -1;
  float nearest_distance = std::numeric_limits<float>::infinity();
  float second_distance = std::numeric_limits<float>::infinity();
};

// Exact search by brute force over reference.packed(), on `threads` threads (> 0). Each squared distance
// kept is the sum of the 33 squared bin differences in bin order, in float, without fused multiply-adds:
// the sum FLANN's kd-tree computes (PCL's L2_Simple), so the distances equal the exact kd-tree's bit for
// bit. (With AVX2 the candidates are screened first by |q|^2 + |t|^2 - 2 q.t with a margin above its
// rounding error; only the direct sum decides.) Without `reverse`, each group of queries of similar norm
// scans the tiles outward from its norm and stops where | |q| - |t| |, a lower bound on |q - t|, exceeds
// every query's second nearest distance with a margin above the rounding: the same two nearest as the
// scan of every pair, for a fraction of its pairs (doc/decisions/exact-descriptor-search.md).
// Ties go to the lowest reference index (the second distance then equals the nearest). With `reverse`,
// the same scan also gives each reference descriptor's nearest query (ties: the lowest query index;
// second_distance left infinite) into *reverse, reference.size() entries. The results do not depend on
// the number of threads. Throws Cancelled when `stop` is raised before it is done (read every chunk of
// queries).
std::vector<NearestDescriptors> nearestDescriptorsBruteForce(
    const FpfhCloud& queries, const DescriptorIndex& reference, int threads,
    std::vector<NearestDescriptors>* reverse = nullptr, const StopFlag* stop = nullptr);

// The k (1 or 2) nearest by reference.tree(), exact for epsilon = 0, else within (1 + epsilon) of the
// nearest distance, for the queries at `which` (all when null; the other entries stay empty). Throws
// Cancelled when `stop` is raised before it is done.
std::vector<NearestDescriptors> nearestDescriptorsKdTree(const FpfhCloud& queries,
                                                         const std::vector<int>* which,
                                                         const DescriptorIndex& reference, int k,
                                                         double epsilon, int threads,
                                                         const StopFlag* stop = nullptr);

// Each source descriptor's nearest target descriptor (params.match_epsilon = 0: exact, by brute force, ties
// to the lowest target index; else the kd-tree, within (1 + match_epsilon) of the nearest distance),
// optionally kept only when mutual (params.mutual_filter) and distinctive (params.ratio_test); then the
// params.max_correspondences closest, ascending by distance (ties by source index: deterministic). Throws
// Cancelled when `stop` is raised before it is done.
std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats,
                                        const StopFlag* stop = nullptr);

// The same on indices built before (either may be built or not yet). Brute force: the target's packed
// descriptors are scanned by every source descriptor, and the mutual check's reverse nearest comes from
// the same scan (the source's index is not searched). Kd-tree: the target's tree is searched by every
// source descriptor, the source's only with params.mutual_filter, by the targets some source descriptor
// found nearest. The same matches as above, bit for bit.
std::vector<FeatureMatch> matchFeatures(const DescriptorIndex& source, const DescriptorIndex& target,
                                        const FeatureParams& params, MatchingStats& stats,
                                        const StopFlag* stop = nullptr);

}  // namespace mac_registration
