#pragma once

#include <Eigen/Core>
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
// the cloud was read despite; the caller shows them (mac_register prints them on stderr). A map in global
// coordinates: loadLocalCloud.
PointCloud::Ptr loadCloud(const std::string& path, std::vector<std::string>* warnings = nullptr);

// A cloud in a frame of its own: a point of the file is a point of `cloud` plus `origin` [m], whole metres.
struct LocalCloud {
  PointCloud::Ptr cloud;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
};

// [m] Coordinates within this of zero need no local origin: float32 spaces them at most 2^-10 m apart
// (10^4 < 2^14), half a millimetre off at worst.
constexpr double kLocalFrameBound = 1.0e4;

// Reads a map in global coordinates (UTM: eastings ~5e5 m, northings ~5e6 m, as PCD fields of TYPE F SIZE 8
// or PLY double properties hold them to the millimetre) in a local frame. float32 spaces coordinates 0.5 m
// apart at a northing, and loadCloud refuses them beyond kMaxAbsCoordinate; this reads the same files, with
// the same errors and warnings, but keeps the coordinates in double until the origin is taken off them.
// The origin, axis by axis: 0 when the finite points' coordinates all lie within kLocalFrameBound (a small
// cloud stays in the file's frame and reads as loadCloud reads it; a UTM map keeps its heights), else the
// median of them rounded to whole metres. The median, not the mean: a few misdecoded values (1e30) cannot
// drag it off the map, so the bound refuses them by name instead of the good points. The cloud holds each
// point (and VIEWPOINT) less the origin in float, and kMaxAbsCoordinate bounds these local coordinates: a
// map reaching up to 10^6 m either side of its median is read wherever it lies, within 10 km of the origin
// to half a millimetre. A transform T into the local frame is Translation3d(origin) * T into the file's.
LocalCloud loadLocalCloud(const std::string& path, std::vector<std::string>* warnings = nullptr);

// The local origin loadLocalCloud takes for these points (non-finite ones ignored): for callers that hold
// global coordinates in memory rather than in a file (the Python module's arrays).
Eigen::Vector3d localOrigin(const std::vector<Eigen::Vector3d>& points);

}  // namespace mac_registration
