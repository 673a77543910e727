// Point-to-plane ICP of the source keypoints onto the target's keypoints and normals, from a global pose:
// the fine alignment the cloud witness offers the verification. Internal to the features library.
#pragma once

#include <Eigen/Geometry>

#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/features/point_cloud.hpp"
#include "radius_search.hpp"

namespace mac_registration {

// `target_grid` holds the target keypoints within the pairing distance (its radius): a source point is
// paired with its nearest target point within it. Up to `max_iterations` Gauss-Newton steps on the sum of
// squared point-to-plane residuals; the same pose on any thread count.
FineAlignment alignPointToPlane(const PointCloud& source, const PointCloud& target,
                                const pcl::PointCloud<pcl::Normal>& target_normals,
                                const CloudGrid& target_grid, const Eigen::Isometry3d& start,
                                int max_iterations, int threads);

}  // namespace mac_registration
