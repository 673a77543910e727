#pragma once

#include <cstddef>
#include <string>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// The points with three finite coordinates, as an unorganized cloud (an organized
// cloud's NaN pixels go too). `dropped` receives how many were removed.
PointCloud::Ptr finitePoints(const PointCloud& cloud, std::size_t& dropped);

// [m] The diagonal of the bounding box of the cloud's finite points; 0 for none. `finite` receives how
// many there are.
double finiteDiagonal(const PointCloud& cloud, std::size_t& finite);

// [m] The largest |coordinate| a cloud may have where it enters the front end (loadCloud, describeCloud and
// the ROS reader). 10^6 m holds any UTM easting and any map in a local frame up to a UTM zone's width, and
// float32 still spaces coordinates 6.25 cm apart there, finer than an outdoor voxel; beyond it a cloud is
// misdecoded or in global coordinates (UTM northings: 1 m steps; loadLocalCloud reads those in a local
// frame), and its squared distances would overflow the kd-trees' float arithmetic at ~10^19 m. Finer voxels
// need a tighter bound: see describeCloud.
constexpr double kMaxAbsCoordinate = 1.0e6;

// Why `point` (number `index` of its cloud) is refused: a finite coordinate beyond +-kMaxAbsCoordinate
// ("point 7 has x = 3e+38 m, beyond ..."); empty when it is within. NaN/Inf are left to finitePoints.
std::string coordinateBoundProblem(const pcl::PointXYZ& point, std::size_t index);

// The same for the first such point of `cloud`.
std::string coordinateBoundProblem(const PointCloud& cloud);

}  // namespace mac_registration
