#include "benchmark_runner.hpp"

#include <exception>
#include <memory>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
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
  m.times = result.times;
  return judge(m, criterion);
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
  MacResult result = registerCorrespondences(set, mac);
  if (verify_with_clouds) verify_with_clouds(result);
  return result;
}

PreparedPair preparePair(const BenchmarkPair& pair, const BenchmarkSettings& settings) {
  PreparedPair prepared;
  prepared.mac = settings.mac;
  if (!pair.hasClouds()) {
    prepared.correspondences = readCorrespondencesFile(pair.correspondences_path);
    return prepared;
  }
#ifdef MAC_REGISTRATION_WITH_FEATURES
  const PointCloud::Ptr source = loadCloud(pair.source_path);
  const PointCloud::Ptr target = loadCloud(pair.target_path);
  auto features =
      std::make_shared<FeatureCorrespondences>(computeCorrespondences(*source, *target, settings.features));
  const FrontEndStats& s = features->stats;
  prepared.front_end = {s.resolution_ms, s.downsample_ms, s.normals_ms, s.features_ms, s.matching_ms};
  prepared.correspondences = features->correspondences;
  // The same parameters registerClouds() would use.
  prepared.mac = withResolutionUnits(settings.mac, settings.features, s.resolution);
  if (settings.cloud_verification) {
    prepared.verify_with_clouds = [features, mac = prepared.mac](MacResult& result) {
      verifyAlignment(*features, mac, result);
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
  PreparedPair prepared;
  try {
    prepared = preparePair(pair, settings);
  } catch (const std::exception& e) {
    outcome.error = e.what();
    return outcome;
  }
  const CorrespondenceSet& correspondences = prepared.correspondences;
  outcome.front_end = prepared.front_end;
  outcome.correspondences = correspondences.size();
  outcome.inlier_ratio =
      inlierRatio(correspondences, pair.T_target_source_gt, settings.mac.evaluation.inlier_threshold);

  outcome.methods.push_back(
      outcomeOf("MAC", prepared.registerSet(correspondences), pair.T_target_source_gt, settings.criterion));
#ifdef MAC_REGISTRATION_WITH_FEATURES
  if (settings.baseline) {
    RansacParams ransac;
    ransac.inlier_threshold = settings.mac.evaluation.inlier_threshold;
    ransac.min_inliers = settings.mac.evaluation.min_inliers;
    ransac.max_iterations = settings.ransac_max_iterations;
    outcome.methods.push_back(outcomeOf("RANSAC", registerCorrespondencesRansac(correspondences, ransac),
                                        pair.T_target_source_gt, settings.criterion));
  }
#endif
  return outcome;
}

}  // namespace mac_registration
