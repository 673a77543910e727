#pragma once

#include <string>
#include <vector>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Reads a cloud's points [m, as the file stores them] from
// - .pcd (v0.5 to v0.7; ascii, binary, binary_compressed): the x y z fields, of any numeric TYPE and SIZE,
//   other fields ignored; an organised cloud keeps its WIDTH x HEIGHT grid and its NaN points (the front
//   end drops non-finite points); VIEWPOINT sets sensor_origin_ and sensor_orientation_. A header whose
//   WIDTH x HEIGHT is 0 but POINTS is not (as SLAM pipelines write) is read as POINTS unorganised points,
//   with a warning;
// - .ply (ascii, binary_little_endian, binary_big_endian): the x y z of the vertex element, of any numeric
//   type; other elements (faces, a range scan's grid) are skipped;
// - .bin: KITTI Velodyne scans, float32 x y z intensity.
// Coordinates are converted to float. Throws std::runtime_error naming the file and the reason when it is
// missing or unreadable, breaks its format (an unknown header line, field lists that disagree, a body
// shorter than its header declares or with a non-number in it), has no points, or has a coordinate beyond
// kMaxAbsCoordinate. `warnings`, when given, receives a sentence naming the file for each fault of it that
// the cloud was read despite; the caller shows them (mac_register prints them on stderr).
PointCloud::Ptr loadCloud(const std::string& path, std::vector<std::string>* warnings = nullptr);

}  // namespace mac_registration
