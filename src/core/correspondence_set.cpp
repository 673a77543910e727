#include "mac_registration/core/correspondence_set.hpp"

#include <stdexcept>
#include <string>

namespace mac_registration {

SanitizedCorrespondences sanitizeCorrespondences(const CorrespondenceSet& input) {
  const auto n = input.source_points.cols();
  if (input.target_points.cols() != n) {
    throw std::invalid_argument("source has " + std::to_string(n) + " points but target has " +
                                std::to_string(input.target_points.cols()));
  }
  const bool normals = input.source_normals.cols() > 0 || input.target_normals.cols() > 0;
  if (normals && (input.source_normals.cols() != n || input.target_normals.cols() != n)) {
    throw std::invalid_argument(
        "normals must be given for every correspondence, on both sides, or not at all");
  }
  SanitizedCorrespondences out;
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool finite =
        input.source_points.col(i).allFinite() && input.target_points.col(i).allFinite() &&
        (!normals || (input.source_normals.col(i).allFinite() && input.target_normals.col(i).allFinite()));
    if (finite) out.original_index.push_back(static_cast<int>(i));
  }
  out.dropped_non_finite = static_cast<std::size_t>(n) - out.original_index.size();
  const auto kept = static_cast<Eigen::Index>(out.original_index.size());
  auto& c = out.correspondences;
  c.source_points.resize(3, kept);
  c.target_points.resize(3, kept);
  if (normals) {
    c.source_normals.resize(3, kept);
    c.target_normals.resize(3, kept);
  }
  for (Eigen::Index k = 0; k < kept; ++k) {
    const auto i = out.original_index[k];
    c.source_points.col(k) = input.source_points.col(i);
    c.target_points.col(k) = input.target_points.col(i);
    if (normals) {
      c.source_normals.col(k) = input.source_normals.col(i);
      c.target_normals.col(k) = input.target_normals.col(i);
    }
  }
  return out;
}

}  // namespace mac_registration
