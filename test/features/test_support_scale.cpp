// features.min_feature_neighbours: a sparse cloud's radii grow until its median keypoint's FPFH sphere
// holds the wanted keypoints, and a pair is described at its sparser cloud's scale.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {
namespace {

std::string demoDataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }

// A square grid of `n` x `n` points `spacing` [m] apart on a gently curved sheet (normals and FPFH are
// defined everywhere), each point in a voxel of its own at the leaf used below.
PointCloud gridSheet(int n, double spacing) {
  PointCloud cloud;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double x = (i + 0.5) * spacing, y = (j + 0.5) * spacing;
      cloud.push_back(pcl::PointXYZ(float(x), float(y), float(0.05 * std::sin(0.3 * x) * std::cos(0.2 * y))));
    }
  }
  return cloud;
}

FeatureParams sparseRule(std::size_t neighbours) {
  FeatureParams params;
  params.voxel_size = 0.5;
  params.normal_radius_factor = 2.0;
  params.feature_radius_factor = 3.0;  // 1.5 m
  params.min_feature_neighbours = neighbours;
  return params;
}

TEST(SupportScale, ASparseCloudsRadiiGrowUntilItsMedianKeypointHoldsTheWantedNeighbours) {
  // On a 1 m grid the 24th nearest point (itself the first) is sqrt(8) = 2.83 m away: 1.89 x the 1.5 m
  // radius, a quarter-octave step of 2.
  const PointCloud sparse = gridSheet(40, 1.0);
  EXPECT_DOUBLE_EQ(describeCloud(sparse, sparseRule(24), "source").support_scale, 2.0);
  // 0.5 m apart, the 24th is 1.41 m away, within the radius as given.
  EXPECT_DOUBLE_EQ(describeCloud(gridSheet(80, 0.5), sparseRule(24), "source").support_scale, 1.0);
  // Off, and a scale given by the caller, leave the cloud's own density out of it.
  EXPECT_DOUBLE_EQ(describeCloud(sparse, sparseRule(0), "source").support_scale, 1.0);
  EXPECT_DOUBLE_EQ(describeCloud(sparse, sparseRule(24), "source", nullptr, 1.5).support_scale, 1.5);
  // A cloud far too sparse for its voxel size grows at most kMaxSupportScale.
  EXPECT_DOUBLE_EQ(describeCloud(gridSheet(30, 5.0), sparseRule(24), "source").support_scale,
                   kMaxSupportScale);
}

TEST(SupportScale, APairIsDescribedAtItsSparserCloudsScale) {
  const PointCloud sparse = gridSheet(40, 1.0), dense = gridSheet(80, 0.5);
  const FeatureParams params = sparseRule(24);
  EXPECT_DOUBLE_EQ(computeCorrespondences(sparse, dense, params).stats.support_scale, 2.0);
  EXPECT_DOUBLE_EQ(computeCorrespondences(dense, sparse, params).stats.support_scale, 2.0);
  // Descriptors of two scales are not comparable: matching them is refused, naming the scales.
  const DescribedCloud s = describeCloud(sparse, params, "source"),
                       t = describeCloud(dense, params, "target");
  try {
    matchDescribedClouds(s, t, params);
    ADD_FAILURE() << "clouds described at different scales were matched";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("support scales"), std::string::npos) << e.what();
  }
  // Against a target described before the source was known, the source follows the target's scale.
  const CloudRegistrationResult r = registerCloudToDescribed(sparse, t, params, MacParams());
  EXPECT_NE(r.registration.status, RegistrationStatus::kInvalidInput) << r.registration.message;
  EXPECT_DOUBLE_EQ(r.features.stats.support_scale, 1.0);
  // Candidates: each is matched as its pair would be, whatever the source's own scale.
  const std::vector<CloudRegistrationResult> candidates =
      registerCandidates(dense, {sparse.makeShared(), dense.makeShared()}, params, MacParams());
  ASSERT_EQ(candidates.size(), 2u);
  EXPECT_DOUBLE_EQ(candidates[0].features.stats.support_scale, 2.0);
  EXPECT_DOUBLE_EQ(candidates[1].features.stats.support_scale, 1.0);
}

TEST(SupportScale, SparseLidarKeyframesAreDescribedWiderAndRegisterWithTheOutdoorPreset) {
  // NCLT keyframes (32-beam, downsampled to 2-5k points by the mapping run), 559 -> 323.
  const PointCloud::Ptr query = loadCloud(demoDataPath("nclt_campus/revisit_query.pcd"));
  const PointCloud::Ptr earlier = loadCloud(demoDataPath("nclt_campus/revisit_earlier.pcd"));
  const Eigen::Isometry3d truth = readTransformFile(demoDataPath("nclt_campus/T_earlier_query.txt"));
  RegistrationConfig preset;
  loadPresetFile(preset, std::string(MAC_CONFIG_DIR) + "/outdoor_lidar.yaml");
  ASSERT_GT(preset.features.min_feature_neighbours, 0u);
  const CloudRegistrationResult r = registerClouds(*query, *earlier, preset.features, preset.mac);
  EXPECT_GT(r.features.stats.support_scale, 1.0);
  EXPECT_LE(r.features.stats.support_scale, kMaxSupportScale);
  ASSERT_TRUE(r.registration.success) << r.registration.message;
  EXPECT_LT(rotationErrorDeg(r.registration.T_target_source, truth), 2.0);
  EXPECT_LT(translationError(r.registration.T_target_source, truth), 0.5);
}

}  // namespace
}  // namespace mac_registration
