#include "mac_registration/config/feature_params.hpp"

#include <cmath>
#include <sstream>

namespace mac_registration {
namespace {

std::string describe(const char* name, double value, const char* range) {
  std::ostringstream text;
  text << "features." << name << " = " << value << " is out of range: must be " << range;
  return text.str();
}

}  // namespace

std::vector<std::string> validateFeatureParams(const FeatureParams& p) {
  std::vector<std::string> problems;
  const auto check = [&](bool ok, const char* name, double value, const char* range) {
    if (!ok) problems.push_back(describe(name, value, range));
  };
  check(std::isfinite(p.voxel_size) && p.voxel_size >= 0.0, "voxel_size", p.voxel_size,
        "> 0 [m], or 0 (auto)");
  check(std::isfinite(p.normal_radius_factor) && p.normal_radius_factor > 0.0, "normal_radius_factor",
        p.normal_radius_factor, "> 0");
  // FPFH histograms pairs of neighbours by their normals: a support no wider than the normals' own gives
  // near-constant angles and no descriptive power.
  check(std::isfinite(p.feature_radius_factor) && p.feature_radius_factor > p.normal_radius_factor,
        "feature_radius_factor", p.feature_radius_factor, "> normal_radius_factor");
  // A surface grid as coarse as the FPFH radius leaves a keypoint a point or two to describe it by. (1, the
  // keypoints themselves, is always usable: a bad radius is that parameter's own problem.)
  check(std::isfinite(p.support_voxel_factor) && p.support_voxel_factor >= 1.0 &&
            (p.support_voxel_factor == 1.0 || p.support_voxel_factor < p.feature_radius_factor),
        "support_voxel_factor", p.support_voxel_factor, ">= 1 and, above 1, < feature_radius_factor");
  check(p.max_correspondences >= 3, "max_correspondences", double(p.max_correspondences), ">= 3");
  check(p.ratio_test == 0.0 || (p.ratio_test > 0.0 && p.ratio_test < 1.0), "ratio_test", p.ratio_test,
        "0 (off) or in (0, 1)");
  check(std::isfinite(p.match_epsilon) && p.match_epsilon >= 0.0, "match_epsilon", p.match_epsilon,
        ">= 0 (0 = exact)");
  check(p.num_threads >= 0, "num_threads", p.num_threads, ">= 0 (0 = OpenMP default)");
  check(std::isfinite(p.gaussian_sigma_resolutions) && p.gaussian_sigma_resolutions >= 0.0,
        "gaussian_sigma_resolutions", p.gaussian_sigma_resolutions, "0 (off) or > 0 [resolutions]");
  check(p.resolution_samples >= 100, "resolution_samples", double(p.resolution_samples), ">= 100");
  return problems;
}

}  // namespace mac_registration
