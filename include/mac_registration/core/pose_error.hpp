#pragma once

#include <Eigen/Geometry>

namespace mac_registration {

// Rotation error [deg] (angle of R_a^T R_b) and translation error [m] between two transforms.
double rotationErrorDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);
double translationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

}  // namespace mac_registration
