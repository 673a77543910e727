// mac_register: registers two clouds (PCL front end, then MAC) or one correspondence set, and prints
// T_target_source.
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/text_io.hpp"
#include "result_report.hpp"
#include "tool_arguments.hpp"
#ifdef MAC_REGISTRATION_WITH_FEATURES
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#endif

namespace {

constexpr const char* kUsage =
    "usage: mac_register SOURCE TARGET [--config FILE] [--set KEY=VALUE]... [--out FILE]\n"
    "                    [--save-correspondences FILE]\n"
    "       mac_register --correspondences FILE [--config FILE] [--set KEY=VALUE]... [--out FILE]\n"
    "  SOURCE, TARGET: clouds (.pcd, .ply, or KITTI .bin: float32 x y z intensity) [m]; the transform maps\n"
    "    SOURCE into TARGET's frame\n"
    "  --correspondences: one correspondence a line, 'xs ys zs xt yt zt' [m], instead of clouds\n"
    "  --config: a YAML preset (see config/); --set overrides one parameter, e.g. --set graph.t_cmp=0.995\n"
    "    or --set features.voxel_size=0.03\n"
    "  --out: also write the 4x4 T_target_source there (4 lines of 4 numbers)\n"
    "  --save-correspondences: write the front end's matches in the --correspondences format\n"
    "exit status: 0 registered and verified, 1 registration failed or not verified (reason printed), 2 bad\n"
    "arguments, unreadable or unusable input\n";

struct Options {
  std::vector<std::string> clouds;
  std::string correspondences, config, out, save_correspondences;
  std::vector<std::string> overrides;
};

Options parseArguments(int argc, char** argv) {
  Options options;
  const mac_registration::ToolArguments common = mac_registration::parseToolArguments(
      argc, argv, [&](const std::string& option, const std::function<std::string()>& value) {
        if (option == "--correspondences")
          options.correspondences = value();
        else if (option == "--save-correspondences")
          options.save_correspondences = value();
        else
          return false;
        return true;
      });
  if (common.help) {
    std::cout << kUsage;
    std::exit(0);
  }
  options.clouds = common.positional;
  options.config = common.config;
  options.out = common.out;
  options.overrides = common.overrides;
  if (options.correspondences.empty() == options.clouds.empty()) {
    throw std::invalid_argument(options.clouds.empty()
                                    ? "give SOURCE TARGET or --correspondences FILE"
                                    : "give either SOURCE TARGET or --correspondences, not both");
  }
  if (!options.clouds.empty() && options.clouds.size() != 2)
    throw std::invalid_argument("expected two clouds, SOURCE and TARGET, got " +
                                std::to_string(options.clouds.size()));
#ifndef MAC_REGISTRATION_WITH_FEATURES
  if (!options.clouds.empty())
    throw std::invalid_argument(
        "this build has no PCL front end (MAC_REGISTRATION_CORE_ONLY): use --correspondences");
#endif
  if (!options.save_correspondences.empty() && options.clouds.empty())
    throw std::invalid_argument("--save-correspondences needs SOURCE TARGET");
  return options;
}

#ifdef MAC_REGISTRATION_WITH_FEATURES
void printFrontEnd(std::ostream& out, const mac_registration::FrontEndStats& s, std::size_t correspondences) {
  const auto cloud = [&](const char* role, std::size_t points, std::size_t dropped, std::size_t keypoints,
                         std::size_t no_feature) {
    out << role << ": " << points << " points (" << dropped << " non-finite dropped), " << keypoints
        << " keypoints (" << no_feature << " without a descriptor)\n";
  };
  cloud("source", s.source_points, s.source_dropped, s.source_keypoints, s.source_no_feature);
  cloud("target", s.target_points, s.target_dropped, s.target_keypoints, s.target_no_feature);
  out << std::fixed << std::setprecision(4) << "front end: ";
  // The resolution is estimated only when a parameter is given in resolutions.
  if (s.resolution > 0.0)
    out << "resolution " << s.resolution << " m, ";
  else
    out << "resolution not estimated, ";
  // The radii the descriptors were computed with, when a sparse cloud widened them.
  if (s.support_scale != 1.0) out << "radii widened " << std::setprecision(2) << s.support_scale << "x, ";
  out << std::setprecision(4) << correspondences << " correspondences (" << s.rejected_mutual
      << " rejected by the mutual check, " << s.rejected_ratio << " by the ratio test, " << s.truncated
      << " beyond max_correspondences)\n"
      << std::setprecision(2) << "front-end time [ms]: resolution " << s.times.resolution_ms
      << ", downsample " << s.times.downsample_ms << ", normals " << s.times.normals_ms << ", fpfh "
      << s.times.features_ms << ", matching " << s.times.matching_ms << ", total " << s.times.total_ms
      << "\n";
  out.unsetf(std::ios::fixed);
}

void writeCorrespondences(const std::string& path, const mac_registration::CorrespondenceSet& c) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open '" + path + "' for writing");
  out << std::setprecision(9);
  for (Eigen::Index k = 0; k < c.source_points.cols(); ++k) {
    out << c.source_points(0, k) << " " << c.source_points(1, k) << " " << c.source_points(2, k) << " "
        << c.target_points(0, k) << " " << c.target_points(1, k) << " " << c.target_points(2, k) << "\n";
  }
  if (!out) throw std::runtime_error("failed writing '" + path + "'");
}
#endif

}  // namespace

int main(int argc, char** argv) {
  using namespace mac_registration;
  Options options;
  RegistrationConfig config;
  CorrespondenceSet correspondences;
  try {
    options = parseArguments(argc, argv);
    // A preset's other sections (a benchmark's criterion, say) are not for registering.
    if (!options.config.empty()) loadPresetFile(config, options.config);
    for (const auto& assignment : options.overrides) applyAssignment(config, assignment);
    if (!options.correspondences.empty()) correspondences = readCorrespondencesFile(options.correspondences);
  } catch (const std::exception& e) {
    std::cerr << "mac_register: " << e.what() << "\n" << kUsage;
    return 2;
  }

  MacResult result;
  if (!options.correspondences.empty()) {
    result = registerCorrespondences(correspondences, config.mac);
  } else {
#ifdef MAC_REGISTRATION_WITH_FEATURES
    CloudRegistrationResult cloud_result;
    try {
      // What a cloud was read despite is shown before the next cloud can fail.
      const auto load = [](const std::string& path) {
        std::vector<std::string> warnings;
        PointCloud::Ptr cloud = loadCloud(path, &warnings);
        for (const auto& warning : warnings) std::cerr << "mac_register: warning: " << warning << "\n";
        return cloud;
      };
      const PointCloud::Ptr source = load(options.clouds[0]);
      const PointCloud::Ptr target = load(options.clouds[1]);
      cloud_result = registerClouds(*source, *target, config.features, config.mac);
      if (!options.save_correspondences.empty())
        writeCorrespondences(options.save_correspondences, cloud_result.features.correspondences);
    } catch (const std::exception& e) {
      std::cerr << "mac_register: " << e.what() << "\n";
      return 2;
    }
    result = cloud_result.registration;
    // A front-end failure leaves nothing to report but the reason (below).
    if (cloud_result.features.source_keypoints)
      printFrontEnd(std::cout, cloud_result.features.stats, cloud_result.features.correspondences.size());
#endif
  }
  if (result.status == RegistrationStatus::kInvalidParameters ||
      result.status == RegistrationStatus::kInvalidInput) {
    std::cerr << "mac_register: " << result.message << "\n";
    return 2;
  }
  const bool unverified = result.status == RegistrationStatus::kUnverified;
  std::cout << (unverified ? "T_target_source (unverified: the best estimate, not confirmed):\n"
                           : "T_target_source:\n")
            << formatTransform(result.T_target_source);
  printResultSummary(std::cout, result);
  if (!result.success) {
    std::cerr << "mac_register: registration failed: " << toString(result.status) << ": " << result.message
              << "\n";
    if (unverified)
      std::cerr << "mac_register: the transform above may be wrong; the alternatives listed are its distinct "
                   "rivals (README: what success means)\n";
    return 1;
  }
  if (!options.out.empty()) {
    try {
      writeTransformFile(options.out, result.T_target_source);
    } catch (const std::exception& e) {
      std::cerr << "mac_register: " << e.what() << "\n";
      return 2;
    }
  }
  return 0;
}
