#include <cmath>
#include <limits>
#include <sstream>

#include "mac_registration/features/cloud_filtering.hpp"

namespace mac_registration {

PointCloud::Ptr finitePoints(const PointCloud& cloud, std::size_t& dropped) {
  auto finite = pcl::make_shared<PointCloud>();
  finite->reserve(cloud.size());
  for (const auto& p : cloud.points) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) finite->push_back(p);
  }
  // push_back keeps width = size and height = 1: the result is unorganized even if the input was not.
  finite->header = cloud.header;
  finite->sensor_origin_ = cloud.sensor_origin_;
  finite->sensor_orientation_ = cloud.sensor_orientation_;
  finite->is_dense = true;
  dropped = cloud.size() - finite->size();
  return finite;
}

double finiteDiagonal(const PointCloud& cloud, std::size_t& finite) {
  Eigen::Array3f low = Eigen::Array3f::Constant(std::numeric_limits<float>::max()), high = -low;
  finite = 0;
  for (const auto& p : cloud) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) continue;
    low = low.min(p.getArray3fMap());
    high = high.max(p.getArray3fMap());
    ++finite;
  }
  return finite > 0 ? double((high - low).matrix().norm()) : 0.0;
}

std::string coordinateBoundProblem(const pcl::PointXYZ& point, std::size_t index) {
  const float coordinates[3] = {point.x, point.y, point.z};
  for (int axis = 0; axis < 3; ++axis) {
    // NaN and Inf are dropped and counted by finitePoints, not refused.
    if (std::isfinite(coordinates[axis]) && std::abs(coordinates[axis]) > kMaxAbsCoordinate) {
      std::ostringstream reason;
      reason << "point " << index << " has "
             << "xyz"[axis] << " = " << coordinates[axis] << " m, beyond the front end's bound of +-"
             << kMaxAbsCoordinate
             << " m (past it float32 coordinates are more than 6.25 cm apart, too coarse for a voxel grid: "
                "a misdecoded cloud, or global coordinates to shift to a local origin?)";
      return reason.str();
    }
  }
  return "";
}

std::string coordinateBoundProblem(const PointCloud& cloud) {
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    std::string problem = coordinateBoundProblem(cloud[i], i);
    if (!problem.empty()) return problem;
  }
  return "";
}

}  // namespace mac_registration
