#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace mac_registration {

// A set of putative point correspondences c_i = (source_i, target_i), column i of each matrix.
// Points are in metres, each in its own cloud's frame. Normals are optional (empty matrices, or unit
// vectors column-aligned with the points) and only used by the normal-consistency filter.
struct CorrespondenceSet {
  Eigen::Matrix3Xd source_points;
  Eigen::Matrix3Xd target_points;
  Eigen::Matrix3Xd source_normals;
  Eigen::Matrix3Xd target_normals;

  std::size_t size() const { return static_cast<std::size_t>(source_points.cols()); }
  bool hasNormals() const {
    return source_normals.cols() == source_points.cols() && target_normals.cols() == target_points.cols() &&
           source_normals.cols() > 0;
  }
};

// The correspondences that survived input sanitation, plus where each came from in the caller's set.
struct SanitizedCorrespondences {
  CorrespondenceSet correspondences;
  std::vector<int> original_index;  // original_index[k] = index in the caller's set of column k
  std::size_t dropped_non_finite = 0;
};

// Drops correspondences with a NaN/Inf coordinate (points, or normals when present). Throws
// std::invalid_argument when the source/target (or normal) column counts disagree, because that is a
// caller bug no filtering can repair.
SanitizedCorrespondences sanitizeCorrespondences(const CorrespondenceSet& input);

}  // namespace mac_registration
