#pragma once

#include <Eigen/Geometry>

namespace mac_registration {

// Rotation error [deg] (angle of R_a^T R_b) and translation error [m] between two transforms.
double rotationErrorDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);
double translationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);
// Angle [deg] between the target's z axis and the source's z axis carried into the target by T (roll and
// pitch together; the yaw is free).
double tiltDeg(const Eigen::Isometry3d& T_target_source);

}  // namespace mac_registration
