// mac_relocalize: localizes a query cloud in a map cloud (described once, then searched place by place) and
// prints T_map_query, the pose of the query in the map frame.
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/map_relocalization.hpp"
#include "result_report.hpp"
#include "tool_arguments.hpp"

namespace {

constexpr const char* kUsage =
    "usage: mac_relocalize MAP QUERY [--config FILE] [--set KEY=VALUE]... [--out FILE]\n"
    "  MAP: the map cloud (.pcd, .ply, or KITTI .bin) [m], z up; QUERY: a scan or a local cloud in its own\n"
    "    frame (e.g. the sensor's)\n"
    "  --config: a YAML preset (see config/map_relocalization.yaml); --set overrides one parameter, e.g.\n"
    "    --set relocalization.max_candidates=5\n"
    "  --out: also write the 4x4 T_map_query there (4 lines of 4 numbers)\n"
    "exit status: 0 localized and verified, 1 not localized or ambiguous (reason printed), 2 bad arguments,\n"
    "unreadable or unusable input\n";

mac_registration::ToolArguments parseArguments(int argc, char** argv) {
  mac_registration::ToolArguments arguments = mac_registration::parseToolArguments(argc, argv);
  if (arguments.help) {
    std::cout << kUsage;
    std::exit(0);
  }
  if (arguments.positional.size() != 2)
    throw std::invalid_argument("expected two clouds, MAP and QUERY, got " +
                                std::to_string(arguments.positional.size()));
  return arguments;
}

void printCandidates(std::ostream& out, const mac_registration::RelocalizationResult& result) {
  out << "places (best-ranked first):\n" << std::fixed;
  for (std::size_t k = 0; k < result.candidates.size(); ++k) {
    const auto& c = result.candidates[k];
    out << "  " << k << ": centre (" << std::setprecision(1) << c.centre.x() << ", " << c.centre.y() << ", "
        << c.centre.z() << ") m, score " << c.score << ", " << c.votes << " votes, " << c.keypoints
        << " map keypoints";
    if (c.registered) {
      const auto& r = c.registration.registration;
      out << ": " << mac_registration::toString(r.status) << ", " << r.counters.inliers
          << " inliers, confidence " << std::setprecision(2) << r.confidence;
    }
    out << "\n";
  }
  out.unsetf(std::ios::fixed);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mac_registration;
  ToolArguments options;
  RegistrationConfig config;
  LocalCloud map;
  PointCloud::Ptr query;
  try {
    options = parseArguments(argc, argv);
    if (!options.config.empty()) loadPresetFile(config, options.config);
    for (const auto& assignment : options.overrides) applyAssignment(config, assignment);
    const auto problems = validateConfig(config);
    if (!problems.empty()) throw std::invalid_argument(problems.front());
    std::vector<std::string> warnings;
    map = loadLocalCloud(options.positional[0], &warnings);
    query = loadCloud(options.positional[1], &warnings);
    for (const auto& warning : warnings) std::cerr << "mac_relocalize: warning: " << warning << "\n";
  } catch (const std::exception& e) {
    std::cerr << "mac_relocalize: " << e.what() << "\n" << kUsage;
    return 2;
  }

  DescribedMap described;
  try {
    described = describeMap(*map.cloud, config.features, config.relocalization, nullptr, map.origin);
  } catch (const std::exception& e) {
    std::cerr << "mac_relocalize: the map: " << e.what() << "\n";
    return 2;
  }
  std::cout << std::fixed << std::setprecision(0) << "map: " << map.cloud->size() << " points, "
            << described.cloud.keypoints->size() << " keypoints, " << described.columns << " x "
            << described.rows << " places of " << std::setprecision(1) << described.cell_size
            << " m; described in " << std::setprecision(0) << described.describe_ms << " ms, ~"
            << described.bytes() / (1 << 20) << " MB\n";
  std::cout.unsetf(std::ios::fixed);

  const RelocalizationResult result =
      relocalize(described, *query, config.features, config.mac, config.relocalization);
  if (result.outcome == RelocalizationOutcome::kInvalidInput) {
    std::cerr << "mac_relocalize: " << result.message << "\n";
    return 2;
  }
  std::cout << std::fixed << std::setprecision(0) << "query: " << query->size() << " points, "
            << result.query_keypoints << " keypoints, reach " << std::setprecision(1) << result.query_radius
            << " m; time [ms]: describe " << std::setprecision(0) << result.describe_ms << ", rank "
            << result.ranking_ms << ", register " << result.registration_ms << ", total " << result.total_ms
            << "\n";
  std::cout.unsetf(std::ios::fixed);
  printCandidates(std::cout, result);
  std::cout << (result.success ? "T_map_query:\n"
                               : "T_map_query (not verified: the best estimate, not confirmed):\n")
            << formatTransform(result.T_map_query);
  if (result.chosen >= 0)
    printResultSummary(std::cout, result.candidates[result.chosen].registration.registration);
  if (!result.success) {
    std::cerr << "mac_relocalize: " << toString(result.outcome) << ": " << result.message << "\n";
    return 1;
  }
  if (!options.out.empty()) {
    try {
      writeTransformFile(options.out, result.T_map_query);
    } catch (const std::exception& e) {
      std::cerr << "mac_relocalize: " << e.what() << "\n";
      return 2;
    }
  }
  return 0;
}
