#pragma once

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>
#include <Eigen/Geometry>

#include <vector>

#include "mac_registration/core/correspondence_set.hpp"

namespace mac_registration {

// Two line lists in the target frame, both line_width [m] wide: inlier correspondences (green) and outliers
// (red, at most max_outlier_lines, evenly sampled), each line from T * source point to its target point.
visualization_msgs::MarkerArray correspondenceMarkers(const CorrespondenceSet& correspondences,
                                                      const std::vector<int>& inliers,
                                                      const Eigen::Isometry3d& T_target_source,
                                                      const std_msgs::Header& header, double line_width,
                                                      int max_outlier_lines);

}  // namespace mac_registration
