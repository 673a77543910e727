#include "mac_registration/features/feature_matching.hpp"

#include <omp.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace mac_registration {

// FLANN's single kd-tree, built with PCL's defaults (exact search). Each match searches a copy of it with
// its own epsilon: the copy shares FLANN's index (PCL copies the pointer) and holds only the search
// parameters and PCL's index mapping, so the matches never write to what they share.
struct DescriptorIndex::Tree {
  pcl::KdTreeFLANN<pcl::FPFHSignature33> flann;
};

DescriptorIndex::DescriptorIndex(FpfhCloud::ConstPtr descriptors) : descriptors_(std::move(descriptors)) {}

DescriptorIndex::~DescriptorIndex() = default;

bool DescriptorIndex::built() const { return built_.load(std::memory_order_acquire); }

const DescriptorIndex::Tree& DescriptorIndex::tree() const {
  std::call_once(once_, [this] {
    auto tree = std::make_unique<Tree>();
    tree->flann.setInputCloud(descriptors_);
    tree_ = std::move(tree);
    built_.store(true, std::memory_order_release);
  });
  return *tree_;
}

namespace {

struct Neighbours {
  int nearest = -1;
  float nearest_distance = std::numeric_limits<float>::infinity();
  float second_distance = std::numeric_limits<float>::infinity();  // infinite when there is no second
};

// The k nearest of `reference` to the queries at `which` (all of them when null); the entries of the
// others stay empty. With eps = 0 (PCL's default) the search is exact; with eps > 0 it skips every
// branch that cannot hold a descriptor closer than (nearest found) / (1 + eps): in 33 dimensions most of
// the exact search's time goes into confirming what it has already found. Either way the tree and the
// search are deterministic, so results do not depend on threads.
std::vector<Neighbours> nearestNeighbours(const FpfhCloud& queries, const std::vector<int>* which,
                                          const DescriptorIndex& reference, int k, double epsilon,
                                          int threads) {
  pcl::KdTreeFLANN<pcl::FPFHSignature33> tree = reference.tree().flann;
  tree.setEpsilon(static_cast<float>(epsilon));
  std::vector<Neighbours> result(queries.size());
  const int count = static_cast<int>(which ? which->size() : queries.size());
#pragma omp parallel num_threads(threads)
  {
    pcl::Indices indices(k);
    std::vector<float> squared(k);
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < count; ++i) {
      const int q = which ? (*which)[i] : i;
      const int found = tree.nearestKSearch(queries[q], k, indices, squared);
      if (found < 1) continue;
      result[q].nearest = indices[0];
      result[q].nearest_distance = std::sqrt(squared[0]);
      if (found > 1) result[q].second_distance = std::sqrt(squared[1]);
    }
  }
  return result;
}

// The targets some source descriptor found nearest, ascending: the only ones the mutual check asks about.
std::vector<int> nearestTargets(const std::vector<Neighbours>& forward, std::size_t targets) {
  std::vector<char> found(targets, 0);
  for (const Neighbours& n : forward) {
    if (n.nearest >= 0) found[n.nearest] = 1;
  }
  std::vector<int> which;
  for (int t = 0; t < static_cast<int>(targets); ++t) {
    if (found[t]) which.push_back(t);
  }
  return which;
}

}  // namespace

std::vector<FeatureMatch> matchFeatures(const DescriptorIndex& source, const DescriptorIndex& target,
                                        const FeatureParams& params, MatchingStats& stats) {
  stats = MatchingStats{};
  const FpfhCloud& source_descriptors = *source.descriptors();
  const FpfhCloud& target_descriptors = *target.descriptors();
  if (source_descriptors.empty() || target_descriptors.empty()) return {};
  const int threads = params.num_threads > 0 ? params.num_threads : omp_get_max_threads();
  const bool ratio_test = params.ratio_test > 0.0;
  const std::vector<Neighbours> forward = nearestNeighbours(
      source_descriptors, nullptr, target, ratio_test ? 2 : 1, params.match_epsilon, threads);
  std::vector<Neighbours> backward;
  if (params.mutual_filter) {
    const std::vector<int> asked = nearestTargets(forward, target_descriptors.size());
    backward = nearestNeighbours(target_descriptors, &asked, source, 1, params.match_epsilon, threads);
  }

  std::vector<FeatureMatch> matches;
  matches.reserve(source_descriptors.size());
  for (int s = 0; s < static_cast<int>(forward.size()); ++s) {
    const Neighbours& n = forward[s];
    if (n.nearest < 0) continue;
    if (params.mutual_filter && backward[n.nearest].nearest != s) {
      ++stats.rejected_mutual;
      continue;
    }
    // Lowe's test: a match barely closer than the runner-up is ambiguous (repetitive structure, planes).
    // Two identical runners-up (distance 0 to both) are ambiguous too.
    if (ratio_test && std::isfinite(n.second_distance) &&
        !(n.nearest_distance < params.ratio_test * n.second_distance)) {
      ++stats.rejected_ratio;
      continue;
    }
    matches.push_back({s, n.nearest, n.nearest_distance});
  }
  std::stable_sort(matches.begin(), matches.end(),
                   [](const FeatureMatch& a, const FeatureMatch& b) { return a.distance < b.distance; });
  if (matches.size() > params.max_correspondences) {
    stats.truncated = matches.size() - params.max_correspondences;
    matches.resize(params.max_correspondences);
  }
  return matches;
}

std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats) {
  return matchFeatures(DescriptorIndex(source), DescriptorIndex(target), params, stats);
}

}  // namespace mac_registration
