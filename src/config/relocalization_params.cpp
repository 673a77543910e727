#include "mac_registration/config/relocalization_params.hpp"

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {

std::vector<std::string> validateRelocalizationParams(const RelocalizationParams& params) {
  // The ranges are the table's entries: these parameters have no other schema.
  RegistrationConfig config;
  config.relocalization = params;
  std::vector<std::string> problems;
  for (const auto& entry : parameterTable()) {
    if (entry.key.rfind("relocalization.", 0) != 0) continue;
    std::string problem = rangeProblem(entry, entry.get(config));
    if (!problem.empty()) problems.push_back(std::move(problem));
  }
  return problems;
}

}  // namespace mac_registration
