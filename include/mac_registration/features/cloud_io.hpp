#pragma once

#include <string>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Reads a cloud's points [m, as the file stores them] from
// - .pcd (ascii, binary, binary_compressed): the x y z fields, of any numeric TYPE and SIZE, other fields
//   ignored; an organised cloud keeps its WIDTH x HEIGHT grid and its NaN points (the front end drops
//   non-finite points); VIEWPOINT sets sensor_origin_ and sensor_orientation_;
// - .ply (ascii, binary_little_endian, binary_big_endian): the x y z of the vertex element, of any numeric
//   type; other elements (faces, a range scan's grid) are skipped;
// - .bin: KITTI Velodyne scans, float32 x y z intensity.
// Coordinates are converted to float. Throws std::runtime_error naming the file and the reason when it is
// missing or unreadable, breaks its format (an unknown header line, field lists that disagree, a body
// shorter than its header declares or with a non-number in it), has no points, or has a coordinate beyond
// kMaxAbsCoordinate.
PointCloud::Ptr loadCloud(const std::string& path);

}  // namespace mac_registration
