// The front end and registerClouds on a real 3DMatch pair (redkitchen fragments 4 -> 0, 37 % overlap,
// shipped downsampled to 3 cm) with its ground truth, and on the ways input can be bad.
#include <gtest/gtest.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>
#include <vector>

#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/features/feature_matching.hpp"
#include "mac_registration/features/voxel_downsampling.hpp"

namespace mac_registration {
namespace {

std::string demoDataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }

struct RealPair {
  PointCloud::Ptr source = loadCloud(demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd"));
  PointCloud::Ptr target = loadCloud(demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd"));
  Eigen::Isometry3d truth = readTransformFile(demoDataPath("redkitchen_4_0/T_target_source_gt.txt"));
};

const RealPair& realPair() {
  static const RealPair pair;
  return pair;
}

double inlierRatio(const CorrespondenceSet& c, const Eigen::Isometry3d& T, double threshold) {
  std::size_t inliers = 0;
  for (Eigen::Index k = 0; k < c.source_points.cols(); ++k)
    inliers += (T * c.source_points.col(k) - c.target_points.col(k)).norm() < threshold;
  return double(inliers) / double(c.size());
}

TEST(RealPair, FrontEndFindsCorrespondencesThatAgreeWithTheGroundTruth) {
  const RealPair& pair = realPair();
  const FeatureParams params;  // the indoor defaults: 5 cm voxels
  const FeatureCorrespondences f = computeCorrespondences(*pair.source, *pair.target, params);
  const FrontEndStats& s = f.stats;
  EXPECT_EQ(s.source_points, pair.source->size());
  EXPECT_EQ(s.source_dropped, 0u);
  // 3 cm input on a 5 cm grid: fewer keypoints than points, and most keypoints described.
  EXPECT_LT(s.source_keypoints, s.source_points / 2);
  EXPECT_GT(s.source_keypoints, 1000u);
  EXPECT_LT(s.source_no_feature, s.source_keypoints / 100);
  // Every described source keypoint is matched (no mutual check, no ratio test) up to the cap.
  EXPECT_EQ(f.correspondences.size() + s.truncated, s.source_keypoints - s.source_no_feature);
  EXPECT_LE(f.correspondences.size(), params.max_correspondences);
  ASSERT_EQ(f.source_indices.size(), f.correspondences.size());
  ASSERT_TRUE(f.correspondences.hasNormals());
  // The correspondences are the matched keypoints.
  const auto& k = (*f.source_keypoints)[f.source_indices[7]];
  EXPECT_FLOAT_EQ(float(f.correspondences.source_points(0, 7)), k.x);
  // Measured 10.3 % at tau = 0.1 m. FPFH on 37 % overlap is mostly outliers; MAC needs a few percent.
  // 5 % fails if normals, radii or matching break, while a different FLANN version would not move it.
  EXPECT_GT(inlierRatio(f.correspondences, pair.truth, 0.1), 0.05);
}

TEST(RealPair, RegisterCloudsRecoversTheGroundTruth) {
  const RealPair& pair = realPair();
  const CloudRegistrationResult r = registerClouds(*pair.source, *pair.target, FeatureParams{}, MacParams{});
  ASSERT_TRUE(r.registration.success) << r.registration.message;
  // Measured 1.8 deg / 2.2 cm; the 3DMatch criterion is 15 deg / 30 cm, and wrong alignments of this
  // pair are tens of degrees off. 5 deg and 10 cm (two voxels) leave room for another platform's float
  // rounding in FPFH, not for a wrong alignment.
  EXPECT_LT(rotationErrorDeg(r.registration.T_target_source, pair.truth), 5.0);
  EXPECT_LT(translationError(r.registration.T_target_source, pair.truth), 0.10);
  // The result's inliers index the returned correspondences.
  ASSERT_FALSE(r.registration.inlier_indices.empty());
  EXPECT_LT(std::size_t(r.registration.inlier_indices.back()), r.features.correspondences.size());
}

// A target described once and matched against a source (the node's cached map) gives exactly what the
// one-call path gives; describing with other radii than the matching's is refused.
TEST(RealPair, ADescribedTargetMatchesLikeTheOneCallPath) {
  const RealPair& pair = realPair();
  const FeatureParams params;
  const DescribedCloud target = describeCloud(*pair.target, params, "target");
  const CloudRegistrationResult once = registerClouds(*pair.source, *pair.target, params, MacParams{});
  const CloudRegistrationResult cached = registerCloudToDescribed(*pair.source, target, params, MacParams{});
  ASSERT_TRUE(cached.registration.success) << cached.registration.message;
  EXPECT_EQ(cached.features.correspondences.source_points, once.features.correspondences.source_points);
  EXPECT_EQ(cached.features.correspondences.target_points, once.features.correspondences.target_points);
  EXPECT_TRUE(cached.registration.T_target_source.matrix() == once.registration.T_target_source.matrix());

  FeatureParams other = params;
  other.voxel_size = 2.0 * params.voxel_size;
  const CloudRegistrationResult refused = registerCloudToDescribed(*pair.source, target, other, MacParams{});
  EXPECT_FALSE(refused.registration.success);
  EXPECT_EQ(refused.registration.status, RegistrationStatus::kInvalidInput);
  EXPECT_NE(refused.registration.message.find("voxel_size"), std::string::npos)
      << refused.registration.message;
}

// NaN points and an organized layout (a depth image's invalid pixels) change nothing but the counters:
// the voxel grid does not depend on where the finite points were stored.
TEST(RealPair, CandidatesShareOneSourceDescriptionAndTheRightOneComesFirst) {
  const RealPair& pair = realPair();
  const FeatureParams features;  // 5 cm voxels: the source is described as the one-call path does
  const MacParams mac;
  // Another place: the outdoor scan shrunk to a room's size.
  auto elsewhere = pcl::make_shared<PointCloud>(*loadCloud(demoDataPath("lidar/lidar_target_251370668.pcd")));
  for (auto& p : *elsewhere) p.getVector3fMap() *= 0.05f;
  const std::vector<PointCloud::ConstPtr> targets = {elsewhere, pair.target, nullptr};
  const std::vector<CloudRegistrationResult> results =
      registerCandidates(*pair.source, targets, features, mac);
  ASSERT_EQ(results.size(), 3u);
  EXPECT_FALSE(results[0].registration.success);
  ASSERT_TRUE(results[1].registration.success) << results[1].registration.message;
  const CloudRegistrationResult alone = registerClouds(*pair.source, *pair.target, features, mac);
  EXPECT_TRUE(results[1].registration.T_target_source.isApprox(alone.registration.T_target_source, 1e-9));
  EXPECT_LT(rotationErrorDeg(results[1].registration.T_target_source, pair.truth), 5.0);
  EXPECT_EQ(results[2].registration.status, RegistrationStatus::kInvalidInput);
  EXPECT_NE(results[2].registration.message.find("candidate 2"), std::string::npos);
  const auto order = bestFirst(
      {rankOf(results[0].registration), rankOf(results[1].registration), rankOf(results[2].registration)});
  EXPECT_EQ(order.front(), 1u);
  EXPECT_EQ(order.size(), 3u);
}

TEST(RealPair, NaNsAndOrganizedCloudsGiveTheSameCorrespondences) {
  const RealPair& pair = realPair();
  PointCloud organized;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::size_t nans = 0;
  for (std::size_t i = 0; i < pair.source->size(); ++i) {
    organized.push_back((*pair.source)[i]);
    if (i % 5 == 0) {
      organized.push_back(pcl::PointXYZ(nan, nan, nan));
      ++nans;
    }
  }
  while (organized.size() % 100 != 0) {
    organized.push_back(pcl::PointXYZ(nan, 0.0f, 0.0f));
    ++nans;
  }
  organized.width = 100;
  organized.height = static_cast<std::uint32_t>(organized.size() / 100);
  organized.is_dense = false;

  const FeatureParams params;
  const FeatureCorrespondences clean = computeCorrespondences(*pair.source, *pair.target, params);
  const FeatureCorrespondences dirty = computeCorrespondences(organized, *pair.target, params);
  EXPECT_EQ(dirty.stats.source_points, organized.size());
  EXPECT_EQ(dirty.stats.source_dropped, nans);
  EXPECT_EQ(dirty.stats.source_keypoints, clean.stats.source_keypoints);
  ASSERT_EQ(dirty.correspondences.size(), clean.correspondences.size());
  EXPECT_TRUE(dirty.correspondences.source_points == clean.correspondences.source_points);
  EXPECT_TRUE(dirty.correspondences.target_points == clean.correspondences.target_points);
}

TEST(BadInput, InvalidFeatureParametersAreRefusedWithTheirName) {
  FeatureParams params;
  params.voxel_size = -0.05;
  params.feature_radius_factor = 1.0;  // below normal_radius_factor 2
  const auto problems = validateFeatureParams(params);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_NE(problems[0].find("voxel_size"), std::string::npos);
  EXPECT_NE(problems[1].find("feature_radius_factor"), std::string::npos);

  const PointCloud::Ptr cloud = realPair().source;
  EXPECT_THROW(computeCorrespondences(*cloud, *cloud, params), std::invalid_argument);
  const CloudRegistrationResult r = registerClouds(*cloud, *cloud, params, MacParams{});
  EXPECT_FALSE(r.registration.success);
  EXPECT_EQ(r.registration.status, RegistrationStatus::kInvalidParameters);
  EXPECT_NE(r.registration.message.find("voxel_size"), std::string::npos);

  EXPECT_TRUE(validateFeatureParams(FeatureParams{}).empty());
  params = FeatureParams{};
  params.ratio_test = 1.0;
  params.max_correspondences = 2;
  EXPECT_EQ(validateFeatureParams(params).size(), 2u);
}

TEST(BadInput, ASupportSurfaceFinerThanTheKeypointsOrAsCoarseAsTheRadiusIsRefused) {
  FeatureParams params;
  for (const double factor : {0.5, 0.0, -1.0, 5.0, 6.0, std::numeric_limits<double>::quiet_NaN(),
                              std::numeric_limits<double>::infinity()}) {
    params.support_voxel_factor = factor;
    const auto problems = validateFeatureParams(params);
    ASSERT_EQ(problems.size(), 1u) << factor;
    EXPECT_NE(problems[0].find("support_voxel_factor"), std::string::npos) << problems[0];
    EXPECT_NE(problems[0].find("feature_radius_factor"), std::string::npos) << problems[0];
  }
  for (const double factor : {1.0, 1.5, 4.9}) {
    params.support_voxel_factor = factor;
    EXPECT_TRUE(validateFeatureParams(params).empty()) << factor;
  }
  params.support_voxel_factor = 0.5;
  const PointCloud::Ptr cloud = realPair().source;
  const CloudRegistrationResult r = registerClouds(*cloud, *cloud, params, MacParams{});
  EXPECT_EQ(r.registration.status, RegistrationStatus::kInvalidParameters);
  EXPECT_NE(r.registration.message.find("support_voxel_factor"), std::string::npos);
}

TEST(BadInput, CloudsWithoutThreeFinitePointsFailAsInvalidInput) {
  PointCloud all_nan;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 10; ++i) all_nan.push_back(pcl::PointXYZ(nan, nan, nan));
  const CloudRegistrationResult r = registerClouds(all_nan, *realPair().target, FeatureParams{}, MacParams{});
  EXPECT_FALSE(r.registration.success);
  EXPECT_EQ(r.registration.status, RegistrationStatus::kInvalidInput);
  EXPECT_NE(r.registration.message.find("source cloud has 0 finite points"), std::string::npos)
      << r.registration.message;
  EXPECT_THROW(computeCorrespondences(*realPair().source, PointCloud{}, FeatureParams{}),
               std::invalid_argument);
}

// Finite but absurd coordinates (a misdecoded cloud, planted 3e38) used to abort the process in FLANN;
// they are refused as invalid input naming the cloud, the point and the bound, before any kd-tree.
TEST(BadInput, CoordinatesBeyondTheBoundFailAsInvalidInputNamingTheCloud) {
  for (const float far : {3e38f, -1e20f, 2e6f}) {
    PointCloud source = *realPair().source;
    source[7].x = far;
    const CloudRegistrationResult r =
        registerClouds(source, *realPair().target, FeatureParams{}, MacParams{});
    EXPECT_FALSE(r.registration.success);
    EXPECT_EQ(r.registration.status, RegistrationStatus::kInvalidInput);
    EXPECT_NE(r.registration.message.find("source cloud: point 7 has x = "), std::string::npos)
        << r.registration.message;
    EXPECT_NE(r.registration.message.find("+-1e+06 m"), std::string::npos) << r.registration.message;
    PointCloud target = *realPair().target;
    target[0].z = far;
    EXPECT_THROW(describeCloud(target, FeatureParams{}, "target"), std::invalid_argument);
  }
}

// Within the bound but far out, float32 steps outgrow the voxel: refused for a fine voxel, accepted for a
// coarse one (at 5e5 m float32 values are 3.1 cm apart).
TEST(BadInput, CoordinatesTooCoarseInFloat32ForTheVoxelSizeAreRefused) {
  PointCloud far_away;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      far_away.push_back(pcl::PointXYZ(5e5f + i * 0.5f, j * 0.5f, float((i * j) % 3) * 0.3f));
  FeatureParams fine;  // 5 cm voxels
  try {
    describeCloud(far_away, fine, "source");
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("source cloud: its coordinates reach 500010 m, where float32 values "
                                         "are 0.03125 m apart"),
              std::string::npos)
        << e.what();
  }
  FeatureParams coarse;
  coarse.voxel_size = 0.3;
  EXPECT_EQ(describeCloud(far_away, coarse, "source").points, far_away.size());
}

// A plane has near-identical FPFH everywhere: whatever the matches, a pose that tilts the plane out of
// itself would be wrong; a failure must say why.
TEST(BadInput, AFeaturelessPlaneGivesAnInPlanePoseOrAFailure) {
  PointCloud plane;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) plane.push_back(pcl::PointXYZ(i * 0.02f, j * 0.02f, 1.0f));
  const CloudRegistrationResult r = registerClouds(plane, plane, FeatureParams{}, MacParams{});
  if (r.registration.success) {
    // Sliding along the plane is allowed; leaving it is not.
    const Eigen::Vector3d normal = r.registration.T_target_source.linear() * Eigen::Vector3d::UnitZ();
    EXPECT_GT(std::abs(normal.z()), 0.99);
  } else {
    EXPECT_FALSE(r.registration.message.empty());
  }
}

TEST(RealPair, TheResolutionIsEstimatedOnlyWhenTheGaussianSigmaIsInResolutions) {
  const RealPair& pair = realPair();
  FeatureParams params;
  ASSERT_FALSE(resolutionNeeded(params));
  EXPECT_EQ(describeCloud(*pair.source, params, "source").resolution, 0.0);
  params.gaussian_sigma_resolutions = 10.0;
  ASSERT_TRUE(resolutionNeeded(params));
  // The 3 cm voxel centroids lie ~1.9 cm apart (measured 0.0185 m).
  const double resolution = describeCloud(*pair.source, params, "source").resolution;
  EXPECT_GT(resolution, 0.012);
  EXPECT_LT(resolution, 0.03);
}

TEST(RealPair, ACoarserSupportSurfaceStillMatchesAndIsRecordedWithTheDescriptors) {
  const RealPair& pair = realPair();
  FeatureParams params;
  params.support_voxel_factor = 2.0;
  const DescribedCloud s = describeCloud(*pair.source, params, "source");
  const DescribedCloud t = describeCloud(*pair.target, params, "target");
  // A quarter of the keypoints or so: the surface's points scale with its area.
  EXPECT_GT(s.support_points, s.voxels / 8);
  EXPECT_LT(s.support_points, s.voxels / 2);
  const FeatureCorrespondences c = matchDescribedClouds(s, t, params);
  EXPECT_GT(inlierRatio(c.correspondences, pair.truth, 0.1), 0.03);
  // Descriptors depend on the surface: a cloud described on another one is refused, naming the reason.
  const FeatureParams keypoint_surface;
  EXPECT_FALSE(describedWith(s, keypoint_surface));
  const DescribedCloud plain = describeCloud(*pair.target, keypoint_surface, "target");
  // Its surface is the keypoints with a normal: every described one, and at most every voxel.
  EXPECT_GE(plain.support_points, plain.keypoints->size());
  EXPECT_LE(plain.support_points, plain.voxels);
  try {
    matchDescribedClouds(s, plain, params);
    ADD_FAILURE() << "matched descriptors of different surfaces";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("support"), std::string::npos) << e.what();
  }
}

// Matches of every described source keypoint, by source index: what the exact and the approximate
// searches are compared on.
std::vector<FeatureMatch> allMatches(const DescribedCloud& s, const DescribedCloud& t, double epsilon,
                                     int threads) {
  FeatureParams params;
  params.match_epsilon = epsilon;
  params.num_threads = threads;
  params.max_correspondences = s.descriptors->size();
  MatchingStats stats;
  std::vector<FeatureMatch> matches = matchFeatures(s.descriptors, t.descriptors, params, stats);
  std::sort(matches.begin(), matches.end(),
            [](const FeatureMatch& a, const FeatureMatch& b) { return a.source < b.source; });
  return matches;
}

TEST(RealPair, ApproximateMatchingKeepsItsBoundAndNearlyAllExactMatches) {
  const RealPair& pair = realPair();
  const FeatureParams params;
  const DescribedCloud s = describeCloud(*pair.source, params, "source");
  const DescribedCloud t = describeCloud(*pair.target, params, "target");
  const double epsilon = 1.0;
  const std::vector<FeatureMatch> exact = allMatches(s, t, 0.0, 0);
  const std::vector<FeatureMatch> approximate = allMatches(s, t, epsilon, 0);
  ASSERT_EQ(exact.size(), s.descriptors->size());
  ASSERT_EQ(approximate.size(), exact.size());
  std::size_t same = 0;
  for (std::size_t k = 0; k < exact.size(); ++k) {
    ASSERT_EQ(approximate[k].source, exact[k].source);
    same += approximate[k].target == exact[k].target;
    // FLANN's guarantee; float rounding of the squared distances aside.
    EXPECT_LE(approximate[k].distance, (1.0 + epsilon) * exact[k].distance * (1.0 + 1e-5) + 1e-7) << k;
    EXPECT_GE(approximate[k].distance, exact[k].distance * (1.0 - 1e-5)) << k;
  }
  // Measured 99.9 % on 3DMatch fragments and KITTI scans; a search that returned the runner-up half the
  // time would still keep its bound but fail here.
  EXPECT_GT(double(same) / double(exact.size()), 0.99);
  // Deterministic: the same matches on one thread as on several.
  const std::vector<FeatureMatch> one_thread = allMatches(s, t, epsilon, 1);
  ASSERT_EQ(one_thread.size(), approximate.size());
  for (std::size_t k = 0; k < one_thread.size(); ++k) EXPECT_EQ(one_thread[k].target, approximate[k].target);
}

TEST(CloudUnits, ScaleTheGaussianSigmaOnlyWhenAsked) {
  MacParams mac;
  mac.graph.gaussian_sigma = 0.05;
  FeatureParams features;
  FrontEndStats stats;
  stats.resolution = 0.01;
  stats.voxel_size = 0.05;
  EXPECT_EQ(inCloudUnits(mac, features, stats).graph.gaussian_sigma, 0.05);
  features.gaussian_sigma_resolutions = 10.0;
  EXPECT_DOUBLE_EQ(inCloudUnits(mac, features, stats).graph.gaussian_sigma, 0.1);
  stats.resolution = 0.0;  // no resolution known
  EXPECT_EQ(inCloudUnits(mac, features, stats).graph.gaussian_sigma, 0.05);
}

TEST(CloudUnits, AutoDistancesFollowTheVoxelSizeAndGivenOnesStay) {
  MacParams mac;
  mac.graph.gaussian_sigma = 0.0;
  mac.graph.quadratic_threshold = 0.0;
  mac.evaluation.inlier_threshold = 0.0;
  FrontEndStats stats;
  stats.voxel_size = 0.003;
  const MacParams derived = inCloudUnits(mac, FeatureParams{}, stats);
  EXPECT_DOUBLE_EQ(derived.graph.gaussian_sigma, kGaussianSigmaVoxels * 0.003);
  EXPECT_DOUBLE_EQ(derived.graph.quadratic_threshold, kQuadraticThresholdVoxels * 0.003);
  EXPECT_DOUBLE_EQ(derived.evaluation.inlier_threshold, kInlierThresholdVoxels * 0.003);
  EXPECT_TRUE(validateParams(derived).empty());
  // The core alone cannot derive them, and says how to give them.
  const auto problems = validateParams(mac);
  ASSERT_EQ(problems.size(), 3u);
  EXPECT_NE(problems[0].find("0 = auto, derived from features.voxel_size"), std::string::npos) << problems[0];
  mac.evaluation.inlier_threshold = 0.25;
  EXPECT_EQ(inCloudUnits(mac, FeatureParams{}, stats).evaluation.inlier_threshold, 0.25);
}

// One scan at three scales, and a sparse copy of it: the auto leaf leaves about the budget of keypoints
// (or half the points of a small cloud) whatever the unit, and scales with the cloud.
TEST(CloudUnits, AutoVoxelSizeLeavesAboutTheKeypointBudgetAtAnyScale) {
  const PointCloud::Ptr room = loadCloud(demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd"));
  PointCloud sparse;
  for (std::size_t i = 0; i < room->size(); i += 8) sparse.push_back((*room)[i]);
  for (const PointCloud* cloud : {room.get(), &sparse}) {
    const double wanted = double(std::min(kAutoVoxelKeypoints, cloud->size() / 2));
    for (const double scale : {0.05, 1.0, 20.0}) {
      PointCloud scaled = *cloud;
      for (auto& p : scaled) p.getVector3fMap() *= float(scale);
      const double voxel = autoVoxelSize(scaled);
      const std::size_t keypoints = voxelDownsample(scaled, voxel, 1)->size();
      // Three square-root steps land within a few per cent on a surface; near the point spacing (the
      // sparse copy) the count no longer grows as 1 / leaf^2 and the steps stop short (measured: 18 %).
      const double tolerance = cloud == room.get() ? 0.1 : 0.25;
      EXPECT_NEAR(double(keypoints), wanted, tolerance * wanted) << cloud->size() << " points x " << scale;
      EXPECT_NEAR(voxel / scale, autoVoxelSize(*cloud), 1e-3 * autoVoxelSize(*cloud)) << scale;
    }
  }
  PointCloud nan_only;
  nan_only.push_back(pcl::PointXYZ(NAN, 0, 0));
  EXPECT_EQ(autoVoxelSize(nan_only), 0.0);
}

// What matching did before the descriptor index: a new tree over each side for every match, and every
// target descriptor searched for the mutual check. The oracle the indexed matching is held to.
std::vector<FeatureMatch> matchesWithFreshTrees(const FpfhCloud::ConstPtr& source,
                                                const FpfhCloud::ConstPtr& target,
                                                const FeatureParams& params, MatchingStats& stats) {
  stats = MatchingStats{};
  const auto nearest = [&](const FpfhCloud& queries, const FpfhCloud::ConstPtr& reference, int k) {
    pcl::KdTreeFLANN<pcl::FPFHSignature33> tree;
    tree.setEpsilon(static_cast<float>(params.match_epsilon));
    tree.setInputCloud(reference);
    std::vector<std::pair<pcl::Indices, std::vector<float>>> found(queries.size());
    for (std::size_t q = 0; q < queries.size(); ++q) {
      found[q].first.resize(k);
      found[q].second.resize(k);
      const int n = tree.nearestKSearch(queries[q], k, found[q].first, found[q].second);
      found[q].first.resize(n);
      found[q].second.resize(n);
    }
    return found;
  };
  const bool ratio = params.ratio_test > 0.0;
  const auto forward = nearest(*source, target, ratio ? 2 : 1);
  const auto backward = params.mutual_filter ? nearest(*target, source, 1) : decltype(forward){};
  std::vector<FeatureMatch> matches;
  for (int s = 0; s < static_cast<int>(forward.size()); ++s) {
    const auto& [indices, squared] = forward[s];
    if (indices.empty()) continue;
    if (params.mutual_filter && backward[indices[0]].first[0] != s) {
      ++stats.rejected_mutual;
      continue;
    }
    const float distance = std::sqrt(squared[0]);
    if (ratio && indices.size() > 1 && !(distance < params.ratio_test * std::sqrt(squared[1]))) {
      ++stats.rejected_ratio;
      continue;
    }
    matches.push_back({s, indices[0], distance});
  }
  std::stable_sort(matches.begin(), matches.end(),
                   [](const FeatureMatch& a, const FeatureMatch& b) { return a.distance < b.distance; });
  if (matches.size() > params.max_correspondences) {
    stats.truncated = matches.size() - params.max_correspondences;
    matches.resize(params.max_correspondences);
  }
  return matches;
}

void expectSameMatches(const std::vector<FeatureMatch>& expected, const std::vector<FeatureMatch>& actual) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    ASSERT_EQ(actual[k].source, expected[k].source) << k;
    ASSERT_EQ(actual[k].target, expected[k].target) << k;
    ASSERT_EQ(actual[k].distance, expected[k].distance) << k;  // bit for bit, not nearly
  }
}

// The search settings the indexed matching is compared on: exact and eps 1, with and without the mutual
// check, and the ratio test (two neighbours a query) with it.
std::vector<FeatureParams> matchingSettings() {
  std::vector<FeatureParams> settings;
  for (const double epsilon : {0.0, 1.0}) {
    for (const bool mutual : {false, true}) {
      FeatureParams p;
      p.match_epsilon = epsilon;
      p.mutual_filter = mutual;
      settings.push_back(p);
    }
    FeatureParams p;
    p.match_epsilon = epsilon;
    p.mutual_filter = true;
    p.ratio_test = 0.9;
    settings.push_back(p);
  }
  return settings;
}

TEST(RealPair, OneDescriptorIndexServesEveryMatchWithTheMatchesOfFreshTrees) {
  const RealPair& pair = realPair();
  const DescribedCloud s = describeCloud(*pair.source, FeatureParams{}, "source");
  const DescribedCloud t = describeCloud(*pair.target, FeatureParams{}, "target");
  ASSERT_TRUE(t.descriptor_index);
  EXPECT_FALSE(t.descriptor_index->built());  // built by the first match, not by the description
  bool some_rejected_mutual = false;
  // The same two indices for every setting: the epsilon of one match does not stick to the next.
  for (const FeatureParams& params : matchingSettings()) {
    SCOPED_TRACE("epsilon " + std::to_string(params.match_epsilon) + ", mutual " +
                 std::to_string(params.mutual_filter) + ", ratio " + std::to_string(params.ratio_test));
    MatchingStats fresh_stats, indexed_stats;
    const auto fresh = matchesWithFreshTrees(s.descriptors, t.descriptors, params, fresh_stats);
    const auto indexed = matchFeatures(*s.descriptor_index, *t.descriptor_index, params, indexed_stats);
    expectSameMatches(fresh, indexed);
    EXPECT_EQ(indexed_stats.rejected_mutual, fresh_stats.rejected_mutual);
    EXPECT_EQ(indexed_stats.rejected_ratio, fresh_stats.rejected_ratio);
    EXPECT_EQ(indexed_stats.truncated, fresh_stats.truncated);
    some_rejected_mutual |= fresh_stats.rejected_mutual > 0;
    // The described clouds' path uses their indices: the same correspondences.
    const FeatureCorrespondences c = matchDescribedClouds(s, t, params);
    ASSERT_EQ(c.source_indices.size(), fresh.size());
    for (std::size_t k = 0; k < fresh.size(); ++k) {
      ASSERT_EQ(c.source_indices[k], fresh[k].source);
      ASSERT_EQ(c.target_indices[k], fresh[k].target);
    }
  }
  EXPECT_TRUE(some_rejected_mutual);  // else the mutual settings would test nothing
  EXPECT_TRUE(t.descriptor_index->built());
}

TEST(RealPair, ConcurrentMatchesAgainstOneDescribedTargetShareItsIndex) {
  const RealPair& pair = realPair();
  FeatureParams params;
  params.mutual_filter = true;  // both sides' indices searched (the kd-tree's approximate search)
  params.match_epsilon = 1.0;
  params.num_threads = 1;
  const DescribedCloud s = describeCloud(*pair.source, params, "source");
  const DescribedCloud t = describeCloud(*pair.target, params, "target");
  MatchingStats stats;
  const auto expected = matchesWithFreshTrees(s.descriptors, t.descriptors, params, stats);
  // Copies of the described clouds (what the node caches and hands out) share the unbuilt indices; the
  // matches race to build them and then search them together.
  constexpr int kMatches = 4;
  std::vector<FeatureCorrespondences> results(kMatches);
  std::vector<std::thread> threads;
  for (int i = 0; i < kMatches; ++i) {
    threads.emplace_back([&, i] {
      const DescribedCloud source_copy = s, target_copy = t;
      results[i] = matchDescribedClouds(source_copy, target_copy, params);
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_TRUE(t.descriptor_index->built());
  EXPECT_TRUE(s.descriptor_index->built());
  for (const FeatureCorrespondences& c : results) {
    ASSERT_EQ(c.source_indices.size(), expected.size());
    for (std::size_t k = 0; k < expected.size(); ++k) {
      ASSERT_EQ(c.source_indices[k], expected[k].source);
      ASSERT_EQ(c.target_indices[k], expected[k].target);
    }
  }
}

TEST(RealPair, ADescribedCloudWithOtherDescriptorsIsNotSearchedThroughItsOldIndex) {
  const RealPair& pair = realPair();
  const FeatureParams params;
  const DescribedCloud s = describeCloud(*pair.source, params, "source");
  const DescribedCloud t = describeCloud(*pair.target, params, "target");
  matchDescribedClouds(s, t, params);  // builds t's index
  // The target's index, the source's points and descriptors: the source matched to itself.
  DescribedCloud swapped = s;
  swapped.descriptor_index = t.descriptor_index;
  const FeatureCorrespondences c = matchDescribedClouds(s, swapped, params);
  MatchingStats stats;
  const auto expected = matchesWithFreshTrees(s.descriptors, s.descriptors, params, stats);
  ASSERT_EQ(c.target_indices.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) ASSERT_EQ(c.target_indices[k], expected[k].target);
}

// The scan tiled `tiles` x `tiles` times, 5 m apart: each copy keeps its keypoints, so the description
// grows with the copies (~4 000 keypoints each).
PointCloud tiledCloud(const PointCloud& scan, int tiles) {
  PointCloud tiled;
  tiled.reserve(std::size_t(tiles) * tiles * scan.size());
  for (int i = 0; i < tiles; ++i) {
    for (int j = 0; j < tiles; ++j) {
      for (const auto& p : scan) tiled.push_back(pcl::PointXYZ(p.x + 5.0f * i, p.y + 5.0f * j, p.z));
    }
  }
  return tiled;
}

TEST(Stop, ARaisedFlagCancelsBeforeTheFrontEnd) {
  const StopFlag stop{true};
  const CloudRegistrationResult r =
      registerClouds(*realPair().source, *realPair().target, FeatureParams{}, MacParams{}, &stop);
  EXPECT_EQ(r.registration.status, RegistrationStatus::kCancelled) << r.registration.message;
  EXPECT_NE(r.registration.message.find("describing the source cloud"), std::string::npos)
      << r.registration.message;
  EXPECT_THROW(describeCloud(*realPair().target, FeatureParams{}, "target", &stop), Cancelled);
}

// A stop raised while a large cloud is described ends the registration within a few of the front end's
// checks (every 4096 points of a pass), not after the description's seconds.
TEST(Stop, AFlagRaisedDuringTheDescriptionOfALargeCloudEndsItPromptly) {
  const PointCloud large = tiledCloud(*realPair().target, 12);  // 1.9 M points, ~600 k keypoints
  StopFlag stop{false};
  for (const int after_ms : {50, 400, 1500}) {  // in the voxel grid, the normals, the FPFH
    stop = false;
    std::chrono::steady_clock::time_point raised;
    std::thread stopper([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(after_ms));
      raised = std::chrono::steady_clock::now();
      stop = true;
    });
    const CloudRegistrationResult r =
        registerClouds(large, *realPair().target, FeatureParams{}, MacParams{}, &stop);
    const auto ended = std::chrono::steady_clock::now();
    stopper.join();
    EXPECT_EQ(r.registration.status, RegistrationStatus::kCancelled) << r.registration.message;
    EXPECT_NE(r.registration.message.find("describing the source cloud"), std::string::npos)
        << r.registration.message;
    const double ms = std::chrono::duration<double, std::milli>(ended - raised).count();
    std::printf("stop raised %d ms into the registration: %s, %.0f ms after it\n", after_ms,
                r.registration.message.c_str(), ms);
    EXPECT_LT(ms, 300.0) << r.registration.message;
  }
}

}  // namespace
}  // namespace mac_registration
