#pragma once

#include <Eigen/Geometry>
#include <string>

#include "mac_registration/core/correspondence_set.hpp"

namespace mac_registration {

// Reads correspondences from text, one a line: "xs ys zs xt yt zt" (blank lines and lines starting with
// '#' are skipped). Throws std::runtime_error naming the file and line when it cannot be read.
CorrespondenceSet readCorrespondencesFile(const std::string& path);

// Reads a 4x4 matrix (16 numbers, row-major; a trailing "0 0 0 1" row may be omitted). Throws
// std::runtime_error when the file has fewer than 12 numbers.
Eigen::Isometry3d readTransformFile(const std::string& path);

// Four lines of four numbers, row-major, full precision.
void writeTransformFile(const std::string& path, const Eigen::Isometry3d& T);
std::string formatTransform(const Eigen::Isometry3d& T);

}  // namespace mac_registration
