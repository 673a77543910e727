#pragma once

#include "benchmark_datasets.hpp"
#include "benchmark_table.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/features/feature_params.hpp"

namespace mac_registration {

struct BenchmarkSettings {
  MacParams mac;
  FeatureParams features;
  SuccessCriterion criterion;
  // The RANSAC baseline on the same correspondences (only in builds with the PCL front end).
  bool baseline = true;
  int ransac_max_iterations = 50000;
};

// Whether this build has the PCL front end (clouds in) and the RANSAC baseline.
bool benchmarkHasFeatures();

// Front end (clouds) or the correspondence file, then MAC and the baseline on the very same
// correspondences, judged against the ground truth. Never throws: a pair that cannot be run comes back
// with `error` set and no method outcomes.
PairOutcome runBenchmarkPair(const BenchmarkPair& pair, const BenchmarkSettings& settings);

}  // namespace mac_registration
