#include "mac_registration/core/pose_error.hpp"

#include <algorithm>
#include <cmath>

namespace mac_registration {

double rotationErrorDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const double cosine = ((a.linear().transpose() * b.linear()).trace() - 1.0) / 2.0;
  return std::acos(std::clamp(cosine, -1.0, 1.0)) * 180.0 / M_PI;
}

double translationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

double tiltDeg(const Eigen::Isometry3d& T_target_source) {
  return std::acos(std::clamp(T_target_source.linear()(2, 2), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace mac_registration
