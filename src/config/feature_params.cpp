#include "mac_registration/config/feature_params.hpp"

#include <set>
#include <sstream>

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {

std::vector<std::string> validateFeatureParams(const FeatureParams& p) {
  std::vector<std::string> problems;
  // The ranges are the table's entries: the front end's parameters have no other schema.
  RegistrationConfig config;
  config.features = p;
  config.mac.num_threads = p.num_threads;
  std::set<std::string> refused;
  for (const auto& entry : parameterTable()) {
    if (entry.key.rfind("features.", 0) != 0 && entry.key != "num_threads") continue;
    std::string problem = rangeProblem(entry, entry.get(config));
    if (problem.empty()) continue;
    problems.push_back(std::move(problem));
    refused.insert(entry.key);
  }
  // The rules between parameters, where both are within their own ranges: a value is refused once.
  const auto rule = [&](const std::string& key, double value, const std::string& other, double bound,
                        const std::string& must) {
    if (refused.count(key) || refused.count(other)) return;
    std::ostringstream text;
    text << key << " = " << value << " [" << findParameter(key)->unit << "] is out of range: must be " << must
         << " " << other << " (" << bound << ").";
    problems.push_back(text.str());
  };
  // FPFH histograms pairs of neighbours by their normals: a support no wider than the normals' own gives
  // near-constant angles and no descriptive power.
  if (!(p.feature_radius_factor > p.normal_radius_factor)) {
    rule("features.feature_radius_factor", p.feature_radius_factor, "features.normal_radius_factor",
         p.normal_radius_factor, ">");
  }
  // A surface grid as coarse as the FPFH radius leaves a keypoint a point or two to describe it by. (1, the
  // keypoints themselves, is always usable: a bad radius is that parameter's own problem.)
  if (p.support_voxel_factor != 1.0 && !(p.support_voxel_factor < p.feature_radius_factor)) {
    rule("features.support_voxel_factor", p.support_voxel_factor, "features.feature_radius_factor",
         p.feature_radius_factor, "1 or <");
  }
  return problems;
}

}  // namespace mac_registration
