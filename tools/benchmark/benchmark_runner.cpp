#include "benchmark_runner.hpp"

#include <algorithm>
#include <exception>
#include <iostream>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "process_memory.hpp"
#ifdef MAC_REGISTRATION_WITH_FEATURES
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/features/cloud_verification.hpp"
#include "ransac_baseline.hpp"
#endif

namespace mac_registration {
namespace {

double inlierRatio(const CorrespondenceSet& c, const Eigen::Isometry3d& T, double threshold) {
  if (c.size() == 0) return 0.0;
  std::size_t inliers = 0;
  for (Eigen::Index k = 0; k < c.source_points.cols(); ++k)
    inliers += (T * c.source_points.col(k) - c.target_points.col(k)).norm() < threshold;
  return double(inliers) / double(c.size());
}

#ifdef MAC_REGISTRATION_WITH_FEATURES
// A cloud, with what it was read despite printed on stderr; once a file, since a scan may be in many pairs.
PointCloud::Ptr loadCloudWarningOnce(const std::string& path) {
  static std::mutex mutex;
  static std::set<std::string> shown;
  std::vector<std::string> warnings;
  PointCloud::Ptr cloud = loadCloud(path, &warnings);
  const std::lock_guard<std::mutex> lock(mutex);
  for (const auto& warning : warnings) {
    if (shown.insert(warning).second) std::cerr << "mac_benchmark: warning: " << warning << "\n";
  }
  return cloud;
}
#endif

MethodOutcome outcomeOf(const std::string& method, const MacResult& result, const Eigen::Isometry3d& truth,
                        const SuccessCriterion& criterion) {
  MethodOutcome m;
  m.method = method;
  m.registered = result.success;
  m.status = toString(result.status);
  // kTooFewInliers and kUnverified still carry the best transform: its error is worth a look in the CSV.
  if (hasEstimate(result)) {
    m.rotation_error_deg = rotationErrorDeg(result.T_target_source, truth);
    m.translation_error = translationError(result.T_target_source, truth);
  }
  m.inliers = result.counters.inliers;
  m.confidence = result.confidence;
  m.times = result.times;
  return judge(m, criterion);
}

MethodOutcome open3dOutcome(const BenchmarkPair& pair, const BenchmarkSettings& settings) {
  MethodOutcome m;
  m.method = "Open3D";
  Open3dCloudsRun run;
  try {
    run = runOpen3dClouds(settings.open3d_settings, pair.source_path, pair.target_path,
                          settings.features.voxel_size, 1);
  } catch (const std::exception& e) {
    m.status = e.what();
    return m;
  }
  // Open3D's RANSAC gives the identity with no inlier when no sample passed its checkers.
  m.registered = run.inliers >= std::max<std::size_t>(3, settings.mac.evaluation.min_inliers);
  m.status = m.registered ? "success" : "too few inliers";
  if (run.inliers > 0) {
    m.rotation_error_deg = rotationErrorDeg(run.T_target_source, pair.T_target_source_gt);
    m.translation_error = translationError(run.T_target_source, pair.T_target_source_gt);
  }
  m.inliers = run.inliers;
  StageTimes f;
  f.downsample_ms = run.downsample_ms;
  f.normals_ms = run.normals_ms;
  f.features_ms = run.fpfh_ms;
  m.front_end = f;
  m.times.total_ms = run.registration_ms;  // its matching included
  m.peak_mb = run.peak_mb;
  return judge(m, settings.criterion);
}

}  // namespace

bool benchmarkHasFeatures() {
#ifdef MAC_REGISTRATION_WITH_FEATURES
  return true;
#else
  return false;
#endif
}

MacResult PreparedPair::registerSet(const CorrespondenceSet& set) const {
  const std::unique_ptr<PoseWitness> witness = cloud_witness ? cloud_witness() : nullptr;
  return registerCorrespondences(set, mac, nullptr, witness.get());
}

PreparedPair preparePair(const BenchmarkPair& pair, const BenchmarkSettings& settings) {
  PreparedPair prepared;
  prepared.mac = settings.mac;
  if (!pair.hasClouds()) {
    prepared.correspondences = readCorrespondencesFile(pair.correspondences_path);
    return prepared;
  }
#ifdef MAC_REGISTRATION_WITH_FEATURES
  const PointCloud::Ptr source = loadCloudWarningOnce(pair.source_path);
  const PointCloud::Ptr target = loadCloudWarningOnce(pair.target_path);
  auto features =
      std::make_shared<FeatureCorrespondences>(computeCorrespondences(*source, *target, settings.features));
  const FrontEndStats& s = features->stats;
  prepared.front_end = s.times;
  prepared.source_points = s.source_points;
  prepared.target_points = s.target_points;
  prepared.correspondences = features->correspondences;
  // The same parameters registerClouds() would use.
  prepared.mac = inCloudUnits(settings.mac, settings.features, s);
  if (settings.cloud_verification) {
    prepared.cloud_witness = [features, mac = prepared.mac]() -> std::unique_ptr<PoseWitness> {
      return std::make_unique<AlignmentJudge>(*features, mac.evaluation.inlier_threshold, mac.num_threads);
    };
  }
  return prepared;
#else
  throw std::runtime_error("this build has no PCL front end: clouds cannot be registered");
#endif
}

PairOutcome runBenchmarkPair(const BenchmarkPair& pair, const BenchmarkSettings& settings) {
  PairOutcome outcome;
  outcome.name = pair.name;
  outcome.subset = pair.subset;
  outcome.scene = pair.scene;
  PreparedPair prepared;
  resetPeakMemory();
  try {
    prepared = preparePair(pair, settings);
  } catch (const std::exception& e) {
    outcome.error = e.what();
    return outcome;
  }
  const CorrespondenceSet& correspondences = prepared.correspondences;
  outcome.front_end = prepared.front_end;
  outcome.source_points = prepared.source_points;
  outcome.target_points = prepared.target_points;
  outcome.correspondences = correspondences.size();
  outcome.inlier_ratio =
      inlierRatio(correspondences, pair.T_target_source_gt, prepared.mac.evaluation.inlier_threshold);

  outcome.methods.push_back(
      outcomeOf("MAC", prepared.registerSet(correspondences), pair.T_target_source_gt, settings.criterion));
  outcome.methods.back().peak_mb = peakMemoryMb();
#ifdef MAC_REGISTRATION_WITH_FEATURES
  if (settings.baseline) {
    RansacParams ransac;
    ransac.inlier_threshold = prepared.mac.evaluation.inlier_threshold;
    ransac.min_inliers = settings.mac.evaluation.min_inliers;
    ransac.max_iterations = settings.ransac_max_iterations;
    outcome.methods.push_back(outcomeOf("RANSAC", registerCorrespondencesRansac(correspondences, ransac),
                                        pair.T_target_source_gt, settings.criterion));
  }
#endif
  if (settings.open3d && pair.hasClouds()) outcome.methods.push_back(open3dOutcome(pair, settings));
  return outcome;
}

// What a reader of the table needs to reproduce it: the front end, MAC's main knobs and the baseline.
void printDatasetSettings(std::ostream& out, const RegistrationConfig& config,
                          const BenchmarkSettings& dataset, bool baseline) {
  const FeatureParams& f = config.features;
  const GraphParams& g = config.mac.graph;
  out << "front end: voxel " << f.voxel_size << " m, normal radius " << f.normal_radius_factor * f.voxel_size
      << " m, FPFH radius " << f.feature_radius_factor * f.voxel_size << " m, max " << f.max_correspondences
      << " correspondences, mutual " << (f.mutual_filter ? "on" : "off") << ", ratio test " << f.ratio_test
      << "\n";
  out << "MAC: " << (g.score == CompatibilityScore::kGaussian ? "gaussian" : "quadratic") << " score, sigma ";
  if (f.gaussian_sigma_resolutions > 0)
    out << f.gaussian_sigma_resolutions << " x resolution";
  else
    out << g.gaussian_sigma << " m";
  out << ", t_cmp " << g.t_cmp << ", tau " << config.mac.evaluation.inlier_threshold << " m\n";
  out << "baseline: ";
  if (baseline)
    out << "RANSAC (PCL), at most " << dataset.ransac_max_iterations << " iterations\n";
  else
    out << (dataset.baseline ? "none (this build has no PCL)" : "none") << "\n";
  if (dataset.open3d) {
    const double v = f.voxel_size;
    out << "peer: Open3D's pipeline on the same clouds (tools/benchmark/open3d_baseline.py): voxel " << v
        << " m, normals in " << 2 * v << " m (max 30 neighbours), FPFH in " << 5 * v
        << " m (max 100), RANSAC on FPFH matches: mutual filter, distance " << 1.5 * v
        << " m, edge-length 0.9 and distance checkers, at most 100000 iterations, confidence 0.999, seed 1\n";
  }
}

}  // namespace mac_registration
