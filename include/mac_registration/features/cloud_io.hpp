#pragma once

#include <string>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Reads a cloud from .pcd, .ply or KITTI .bin (float32 x y z intensity). The header of a .pcd / .ply is
// checked before PCL reads it (known keywords only, consistent field lists and counts, the declared points
// present in the file), and the coordinates against kMaxAbsCoordinate. Throws std::runtime_error naming the
// file and the reason when it is missing, malformed, unreadable or has no points.
PointCloud::Ptr loadCloud(const std::string& path);

}  // namespace mac_registration
