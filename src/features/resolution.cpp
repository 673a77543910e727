#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "mac_registration/features/cloud_filtering.hpp"
#include "mac_registration/features/resolution.hpp"

namespace mac_registration {

double meanNearestNeighbourDistance(const PointCloud::ConstPtr& cloud, std::size_t max_queries,
                                    const StopFlag* stop) {
  const std::size_t n = cloud->size();
  if (n < 2 || max_queries == 0) return 0.0;
  const std::string bound = coordinateBoundProblem(*cloud);
  if (!bound.empty()) throw std::invalid_argument("cannot build a kd-tree: " + bound);
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  // An even stride rather than random picks: the same cloud always gives the same resolution.
  const std::size_t queries = std::min(n, max_queries);
  const double stride = double(n) / double(queries);
  double sum = 0.0;
  std::size_t counted = 0;
  pcl::Indices neighbours(2);
  std::vector<float> squared(2);
  for (std::size_t q = 0; q < queries; ++q) {
    if (q % 1024 == 0) throwIfStopped(stop, "estimating the resolution");
    const auto index = static_cast<pcl::index_t>(std::min(n - 1, std::size_t(q * stride)));
    // k = 2: the first neighbour is the query point itself. A duplicate point gives distance 0, which
    // belongs in the mean: the cloud really is that dense there.
    if (tree.nearestKSearch(index, 2, neighbours, squared) < 2) continue;
    sum += std::sqrt(double(squared[1]));
    ++counted;
  }
  return counted > 0 ? sum / double(counted) : 0.0;
}

}  // namespace mac_registration
