#pragma once

#include <functional>
#include <memory>
#include <ostream>

#include "benchmark_datasets.hpp"
#include "benchmark_table.hpp"
#include "mac_registration/config/feature_params.hpp"
#include "mac_registration/config/parameter_table.hpp"
#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/pose_witness.hpp"
#include "open3d_peer.hpp"

namespace mac_registration {

struct BenchmarkSettings {
  MacParams mac;
  FeatureParams features;
  SuccessCriterion criterion;
  // The RANSAC baseline on the same correspondences (only in builds with the PCL front end).
  bool baseline = true;
  int ransac_max_iterations = 50000;
  // Open3D's own pipeline on the same clouds (pairs with clouds only), its script run once per pair: the
  // voxel size is features.voxel_size, its other parameters the tutorial's in units of it.
  bool open3d = false;
  Open3dSettings open3d_settings;
  // The clouds as the verification's witness (as registerClouds); false judges the correspondences alone,
  // as a caller of registerCorrespondences without a witness gets them.
  bool cloud_verification = true;
};

// Whether this build has the PCL front end (clouds in) and the RANSAC baseline.
bool benchmarkHasFeatures();

// A benchmark pair made ready to register: its correspondences (from the front end, or the file), the
// parameters registerClouds() would use, and with clouds their witness for the verification.
struct PreparedPair {
  CorrespondenceSet correspondences;
  MacParams mac;
  StageTimes front_end;
  std::size_t source_points = 0, target_points = 0;  // as read
  // A new witness of the clouds for one registration (empty for correspondence sets), as registerClouds()
  // builds one. It reads the keypoints only, so it also judges results on other correspondence sets
  // between the same clouds.
  std::function<std::unique_ptr<PoseWitness>()> cloud_witness;

  // The core on `set`, with the clouds as its witness: what registerClouds() does with these clouds.
  MacResult registerSet(const CorrespondenceSet& set) const;
};

// Throws std::runtime_error when the clouds or the file cannot be read or the front end refuses them.
PreparedPair preparePair(const BenchmarkPair& pair, const BenchmarkSettings& settings);

// Front end (clouds) or the correspondence file, then MAC and the baseline on the very same
// correspondences, judged against the ground truth; with settings.open3d, Open3D's pipeline on the same
// clouds (an "Open3D" outcome with its own front end; a failure of the script is its status). MAC's
// peak memory is the process's peak from reading the clouds to MAC's result. Never throws: a pair that cannot
// be run comes back with `error` set and no method outcomes.
PairOutcome runBenchmarkPair(const BenchmarkPair& pair, const BenchmarkSettings& settings);

// What a reader of a dataset table needs to reproduce it: the front end, MAC's main knobs, the baseline and
// the Open3D peer's settings.
void printDatasetSettings(std::ostream& out, const RegistrationConfig& config,
                          const BenchmarkSettings& dataset, bool baseline);

}  // namespace mac_registration
