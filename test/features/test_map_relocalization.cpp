// The map relocalization on the shipped lidar pair: the target scan is the map, placed far from its origin
// beside another place (the shipped indoor fragment scaled to a 30 m building), and the source scan is the
// query. Its pose in the map is the pair's reference transform composed with the placement. A map that holds
// two alike places is an ambiguous answer.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/map_relocalization.hpp"

namespace mac_registration {
namespace {

std::string dataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }

RegistrationConfig relocalizationPreset() {
  RegistrationConfig config;
  loadPresetFile(config, std::string(MAC_CONFIG_DIR) + "/map_relocalization.yaml");
  return config;
}

// Where the test puts the scan's frame in the map: far from the map's origin, turned.
Eigen::Isometry3d placement() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(2500.0, -1200.0, 30.0);
  return T;
}

PointCloud::Ptr transformed(const PointCloud& cloud, const Eigen::Isometry3d& T) {
  PointCloud::Ptr out(new PointCloud);
  for (const auto& p : cloud) {
    pcl::PointXYZ q;
    q.getVector3fMap() = (T * p.getVector3fMap().cast<double>()).cast<float>();
    out->push_back(q);
  }
  return out;
}

// The target scan at placement(), and beside it, 300 m along x, `other` at the same turn.
PointCloud::Ptr twoPlaceMap(const PointCloud& scan, const PointCloud& other) {
  PointCloud::Ptr map = transformed(scan, placement());
  Eigen::Isometry3d shifted = placement();
  shifted.translation().x() += 300.0;
  *map += *transformed(other, shifted);
  return map;
}

// The indoor fragment (3 m across) scaled to a 30 m building: a place of other shapes than a road's.
PointCloud::Ptr building() {
  PointCloud::Ptr cloud = loadCloud(dataPath("redkitchen_4_0/target_cloud_bin_0.pcd"));
  for (auto& p : *cloud) p.getVector3fMap() *= 10.0f;
  return cloud;
}

// The cloud seen in a mirror across the plane normal to `axis` (0 = x, 1 = y).
PointCloud::Ptr mirrored(const PointCloud& cloud, int axis) {
  Eigen::Isometry3d mirror = Eigen::Isometry3d::Identity();
  mirror.linear()(axis, axis) = -1.0;
  return transformed(cloud, mirror);
}

struct Fixture {
  RegistrationConfig config = relocalizationPreset();
  PointCloud::Ptr source = loadCloud(dataPath("lidar/lidar_source_251371071.pcd"));
  PointCloud::Ptr target = loadCloud(dataPath("lidar/lidar_target_251370668.pcd"));
  Eigen::Isometry3d reference = readTransformFile(dataPath("lidar/lidar_T_target_source_reference.txt"));
  DescribedMap map = describeMap(*twoPlaceMap(*target, *building()), config.features, config.relocalization);
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

TEST(MapRelocalization, DescribesTheMapInItsLocalFrame) {
  const DescribedMap& map = fixture().map;
  // The local origin is the map's mean: the keypoints stay within the two places' extent of it.
  EXPECT_GT((map.origin - placement().translation()).norm(), 10.0);
  EXPECT_LT(map.origin.norm(), 3000.0);
  for (const auto& p : *map.cloud.keypoints) ASSERT_LT(std::abs(p.x), 500.0f);
  EXPECT_GT(map.columns * map.rows, 1);
  std::size_t in_cells = 0;
  for (const auto& cell : map.cell_keypoints) in_cells += cell.size();
  EXPECT_EQ(in_cells, map.cloud.keypoints->size());
  EXPECT_DOUBLE_EQ(map.cell_size, kPlaceSpacingVoxels * fixture().config.features.voxel_size);
  EXPECT_GT(map.bytes(), map.cloud.keypoints->size() * sizeof(pcl::FPFHSignature33));
}

TEST(MapRelocalization, FindsTheScanInTheMap) {
  const Fixture& f = fixture();
  const RelocalizationResult r =
      relocalize(f.map, *f.source, f.config.features, f.config.mac, f.config.relocalization);
  ASSERT_TRUE(r.success) << toString(r.outcome) << ": " << r.message;
  EXPECT_EQ(r.outcome, RelocalizationOutcome::kLocalized);
  const Eigen::Isometry3d truth = placement() * f.reference;
  EXPECT_LT(rotationErrorDeg(r.T_map_query, truth), 2.0);
  EXPECT_LT(translationError(r.T_map_query, truth), 0.3);
  ASSERT_GE(r.chosen, 0);
  EXPECT_TRUE(r.candidates[r.chosen].registered);
  EXPECT_TRUE(r.candidates[r.chosen].unconstrained.empty());
  // The chosen place lies at the scan, not at the building 300 m away.
  EXPECT_LT((r.candidates[r.chosen].centre - truth.translation()).head<2>().norm(), 100.0);
  EXPECT_GT(r.query_radius, 5.0);
  // Best-ranked first: the rigidity scores do not rise down the list.
  for (std::size_t k = 1; k < r.candidates.size(); ++k)
    EXPECT_LE(r.candidates[k].score, r.candidates[k - 1].score);
}

TEST(MapRelocalization, MorePlacesRegisteredAskMoreConfidenceOfALocation) {
  // Up to the three places the verification was measured at, its own bar; beyond, odds x places / 3.
  EXPECT_DOUBLE_EQ(locationConfidenceBar(0.5, 1), 0.5);
  EXPECT_DOUBLE_EQ(locationConfidenceBar(0.5, 3), 0.5);
  EXPECT_NEAR(locationConfidenceBar(0.5, 10), 10.0 / 13.0, 1e-12);
  EXPECT_NEAR(locationConfidenceBar(0.8, 6), 8.0 / 9.0, 1e-12);
  EXPECT_DOUBLE_EQ(locationConfidenceBar(0.0, 20), 0.0);  // no bar stays no bar
  // The scan is still found with twenty places registered: the right place's confidence clears the bar.
  const Fixture& f = fixture();
  RelocalizationParams many = f.config.relocalization;
  many.max_candidates = 20;
  many.time_limit = 60.0;
  const RelocalizationResult r = relocalize(f.map, *f.source, f.config.features, f.config.mac, many);
  EXPECT_TRUE(r.success) << toString(r.outcome) << ": " << r.message;
  const auto registered = std::count_if(r.candidates.begin(), r.candidates.end(),
                                        [](const PlaceCandidate& c) { return c.registered; });
  EXPECT_GT(registered, 3);
  EXPECT_GE(r.confidence, locationConfidenceBar(f.config.mac.verification.min_confidence, registered));
}

TEST(MapRelocalization, AMirroredScanIsNotLocalized) {
  // A place that exists nowhere: the scan mirrored front to back, which no rigid motion lays onto the map.
  const Fixture& f = fixture();
  const PointCloud::Ptr query = mirrored(*f.source, 0);
  const RelocalizationResult r =
      relocalize(f.map, *query, f.config.features, f.config.mac, f.config.relocalization);
  EXPECT_FALSE(r.success) << "T_map_query:\n" << r.T_map_query.matrix();
  EXPECT_NE(r.outcome, RelocalizationOutcome::kLocalized);
  EXPECT_FALSE(r.message.empty());
}

// Every other point of `cloud`, from `first` (0 or 1): two scans of one place that are not the same points.
PointCloud::Ptr alternate(const PointCloud& cloud, std::size_t first) {
  PointCloud::Ptr out(new PointCloud);
  for (std::size_t i = first; i < cloud.size(); i += 2) out->push_back(cloud[i]);
  return out;
}

TEST(MapRelocalization, TwoAlikePlacesAreAmbiguous) {
  // The map holds the place twice, 300 m apart, each from half of the scan's points (as two alike corridors
  // would look): both verify, at poses 300 m apart, and neither is the answer.
  const Fixture& f = fixture();
  const DescribedMap map = describeMap(*twoPlaceMap(*alternate(*f.target, 0), *alternate(*f.target, 1)),
                                       f.config.features, f.config.relocalization);
  const RelocalizationResult r =
      relocalize(map, *f.source, f.config.features, f.config.mac, f.config.relocalization);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.outcome, RelocalizationOutcome::kAmbiguous) << r.message;
  EXPECT_NE(r.message.find("ambiguous"), std::string::npos) << r.message;
  std::size_t confirmed = 0;
  for (const auto& c : r.candidates) confirmed += c.registered && c.registration.registration.success;
  EXPECT_GE(confirmed, 2u);
}

TEST(MapRelocalization, ASearchAreaKeepsTheSearchInside) {
  // The two alike places again, with a prior around the first (as a pose estimate clicked in rviz): the
  // other is not searched, and the answer is the first's pose.
  const Fixture& f = fixture();
  const DescribedMap map = describeMap(*twoPlaceMap(*alternate(*f.target, 0), *alternate(*f.target, 1)),
                                       f.config.features, f.config.relocalization);
  const Eigen::Isometry3d truth = placement() * f.reference;
  SearchArea area{truth.translation().head<2>() + Eigen::Vector2d(20.0, -10.0), 100.0};
  const RelocalizationResult r =
      relocalize(map, *f.source, f.config.features, f.config.mac, f.config.relocalization, nullptr, &area);
  ASSERT_TRUE(r.success) << toString(r.outcome) << ": " << r.message;
  EXPECT_LT(translationError(r.T_map_query, truth), 0.3);
  for (const auto& c : r.candidates) EXPECT_LE((c.centre.head<2>() - area.centre).norm(), area.radius);
  // An area the map does not reach, and one that is no area.
  area.centre.x() += 5000.0;
  const RelocalizationResult outside =
      relocalize(map, *f.source, f.config.features, f.config.mac, f.config.relocalization, nullptr, &area);
  EXPECT_EQ(outside.outcome, RelocalizationOutcome::kNotLocalized);
  EXPECT_NE(outside.message.find("search area"), std::string::npos) << outside.message;
  area.radius = 0.0;
  EXPECT_EQ(
      relocalize(map, *f.source, f.config.features, f.config.mac, f.config.relocalization, nullptr, &area)
          .outcome,
      RelocalizationOutcome::kInvalidInput);
}

TEST(MapRelocalization, RefusesWhatItCannotUse) {
  const Fixture& f = fixture();
  RegistrationConfig config = f.config;
  config.features.voxel_size = 0.0;
  EXPECT_THROW(describeMap(*f.target, config.features, config.relocalization), std::invalid_argument);
  config = f.config;
  config.relocalization.max_candidates = 0;
  EXPECT_THROW(describeMap(*f.target, config.features, config.relocalization), std::invalid_argument);
  const RelocalizationResult refused =
      relocalize(f.map, *f.source, f.config.features, f.config.mac, config.relocalization);
  EXPECT_EQ(refused.outcome, RelocalizationOutcome::kInvalidInput);
  EXPECT_NE(refused.message.find("relocalization.max_candidates"), std::string::npos) << refused.message;
  // Other radii than the map's: the descriptors would not be comparable.
  config = f.config;
  config.features.feature_radius_factor = 5.0;
  const RelocalizationResult other =
      relocalize(f.map, *f.source, config.features, config.mac, config.relocalization);
  EXPECT_EQ(other.outcome, RelocalizationOutcome::kInvalidInput);
  PointCloud empty;
  const RelocalizationResult nothing =
      relocalize(f.map, empty, f.config.features, f.config.mac, f.config.relocalization);
  EXPECT_EQ(nothing.outcome, RelocalizationOutcome::kInvalidInput);
  EXPECT_NE(nothing.message.find("query"), std::string::npos) << nothing.message;
}

}  // namespace
}  // namespace mac_registration
