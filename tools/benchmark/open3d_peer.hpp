#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

namespace mac_registration {

// How mac_benchmark runs tools/benchmark/open3d_baseline.py, Open3D's pipeline as a peer of ours.
struct Open3dSettings {
  std::string python = "/usr/bin/python3";  // Debian's interpreter: python3-open3d is installed for it
  std::string script;                       // the script; empty: the one of this source tree
  int threads = 0;                          // OMP_NUM_THREADS of the script, 0: Open3D's default (all)
};

// The script's report on two clouds (its "clouds" mode): times [ms], T_target_source, peak memory.
struct Open3dCloudsRun {
  std::string version;
  std::size_t source_points = 0, target_points = 0, source_keypoints = 0, target_keypoints = 0;
  double read_ms = 0.0;  // reading the files, outside the total as for ours
  double downsample_ms = 0.0, normals_ms = 0.0, fpfh_ms = 0.0;
  double registration_ms = 0.0;  // feature matching and RANSAC
  double total_ms = 0.0;         // the four stages
  double fitness = 0.0;          // inlier share of the source keypoints (Open3D's definition)
  std::size_t inliers = 0;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double peak_mb = 0.0;  // [MiB] maximum resident set of the script's process, interpreter included
};

// One correspondence file in the script's "fgr" mode.
struct FgrRun {
  std::string file;
  std::size_t correspondences = 0;
  double fgr_ms = 0.0;  // registration_fgr_based_on_correspondence alone
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
};

struct Open3dFgrRuns {
  std::string version;
  std::vector<FgrRun> runs;  // in the order of the files
  double peak_mb = 0.0;
};

// Parsers of the script's "key value..." lines. Throw std::runtime_error naming the missing or malformed key.
Open3dCloudsRun parseOpen3dClouds(const std::string& output);
Open3dFgrRuns parseOpen3dFgr(const std::string& output);

// Throws std::runtime_error naming python3-open3d when the script cannot import Open3D, and naming the
// interpreter or the script when those are missing.
void requireOpen3d(const Open3dSettings& settings);

// Open3D's pipeline on two clouds with the tutorial's parameters in units of `voxel_size` [m]; throws
// std::runtime_error with the script's message when it fails.
Open3dCloudsRun runOpen3dClouds(const Open3dSettings& settings, const std::string& source_path,
                                const std::string& target_path, double voxel_size, int seed);

// FGR on each correspondence file, with maximum_correspondence_distance `distance` [m] at absolute scale.
Open3dFgrRuns runOpen3dFgr(const Open3dSettings& settings, const std::vector<std::string>& files,
                           double distance);

}  // namespace mac_registration
