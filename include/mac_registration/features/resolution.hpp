#pragma once

#include <cstddef>

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Mean distance from a point to its nearest other point [m]. At most `max_queries`
// points, spread evenly over the cloud, are queried against the whole cloud. 0 for fewer than 2 points.
// `cloud` must be finite; throws std::invalid_argument when a coordinate is beyond kMaxAbsCoordinate (FLANN
// aborts the process on the overflowing distances of such points). Throws Cancelled when `stop` is raised
// before it is done (read between queries: the kd-tree's build over every point cannot be interrupted).
double meanNearestNeighbourDistance(const PointCloud::ConstPtr& cloud, std::size_t max_queries,
                                    const StopFlag* stop = nullptr);

}  // namespace mac_registration
