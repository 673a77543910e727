#include <omp.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "mac_registration/features/feature_matching.hpp"

namespace mac_registration {
namespace {

struct Neighbours {
  int nearest = -1;
  float nearest_distance = std::numeric_limits<float>::infinity();
  float second_distance = std::numeric_limits<float>::infinity();  // infinite when there is no second
};

// FLANN's single kd-tree. With eps = 0 (PCL's default) the search is exact; with eps > 0 it skips every
// branch that cannot hold a descriptor closer than (nearest found) / (1 + eps): in 33 dimensions most of
// the exact search's time goes into confirming what it has already found. Either way the tree and the
// search are deterministic, so results do not depend on threads.
std::vector<Neighbours> nearestNeighbours(const FpfhCloud& queries, const FpfhCloud::ConstPtr& reference,
                                          int k, double epsilon, int threads) {
  pcl::KdTreeFLANN<pcl::FPFHSignature33> tree;
  tree.setEpsilon(static_cast<float>(epsilon));
  tree.setInputCloud(reference);
  std::vector<Neighbours> result(queries.size());
  const int count = static_cast<int>(queries.size());
#pragma omp parallel num_threads(threads)
  {
    pcl::Indices indices(k);
    std::vector<float> squared(k);
#pragma omp for schedule(dynamic, 64)
    for (int q = 0; q < count; ++q) {
      const int found = tree.nearestKSearch(queries[q], k, indices, squared);
      if (found < 1) continue;
      result[q].nearest = indices[0];
      result[q].nearest_distance = std::sqrt(squared[0]);
      if (found > 1) result[q].second_distance = std::sqrt(squared[1]);
    }
  }
  return result;
}

}  // namespace

std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats) {
  stats = MatchingStats{};
  if (source->empty() || target->empty()) return {};
  const int threads = params.num_threads > 0 ? params.num_threads : omp_get_max_threads();
  const bool ratio_test = params.ratio_test > 0.0;
  const std::vector<Neighbours> forward =
      nearestNeighbours(*source, target, ratio_test ? 2 : 1, params.match_epsilon, threads);
  std::vector<Neighbours> backward;
  if (params.mutual_filter) backward = nearestNeighbours(*target, source, 1, params.match_epsilon, threads);

  std::vector<FeatureMatch> matches;
  matches.reserve(source->size());
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

}  // namespace mac_registration
