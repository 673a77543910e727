#pragma once

#include <cstddef>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Mean distance from a point to its nearest other point [m]. At most `max_queries`
// points, spread evenly over the cloud, are queried against the whole cloud. 0 for fewer than 2 points.
// `cloud` must be finite; throws std::invalid_argument when a coordinate is beyond kMaxAbsCoordinate (FLANN
// aborts the process on the overflowing distances of such points).
double meanNearestNeighbourDistance(const PointCloud::ConstPtr& cloud, std::size_t max_queries);

}  // namespace mac_registration
