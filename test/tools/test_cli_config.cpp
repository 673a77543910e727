// The presets and --set of the tools: core keys, the features: section, and their errors.
#include <gtest/gtest.h>

#include "cli_config.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

std::string configPath(const std::string& name) { return std::string(MAC_CONFIG_DIR) + "/" + name; }

TEST(Presets, IndoorFeaturesSectionIsRead) {
  FeatureParams f;
  f.voxel_size = 1.0;  // anything the preset must overwrite
  loadFeatureParamsFile(f, configPath("indoor_rgbd.yaml"));
  EXPECT_DOUBLE_EQ(f.voxel_size, 0.05);
  EXPECT_DOUBLE_EQ(f.normal_radius_factor, 2.0);
  EXPECT_DOUBLE_EQ(f.feature_radius_factor, 5.0);
  EXPECT_EQ(f.max_correspondences, 5000u);
  EXPECT_FALSE(f.mutual_filter);
}

TEST(Presets, OutdoorFeaturesSectionIsRead) {
  FeatureParams f;
  loadFeatureParamsFile(f, configPath("outdoor_lidar.yaml"));
  EXPECT_DOUBLE_EQ(f.voxel_size, 0.3);
}

// The core-only reader skips features: (and any other section it does not know), and the features
// reader skips the core's sections: each sees only its own keys.
TEST(Presets, EachReaderSeesOnlyItsOwnSection) {
  test::TempDir dir;
  const std::string path = dir.write("preset.yaml",
                                     "graph:\n  t_cmp: 0.995\n"
                                     "features:\n  voxel_size: 0.02  # [m]\n  mutual_filter: true\n"
                                     "ros_node:\n  frame: map\n");
  MacParams mac;
  loadParamsFile(mac, path);
  EXPECT_DOUBLE_EQ(mac.graph.t_cmp, 0.995);
  FeatureParams f;
  loadFeatureParamsFile(f, path);
  EXPECT_DOUBLE_EQ(f.voxel_size, 0.02);
  EXPECT_TRUE(f.mutual_filter);
}

TEST(Presets, ErrorsNameFileLineAndKey) {
  test::TempDir dir;
  const std::string path = dir.write("bad.yaml", "features:\n  voxel_size: 0.05\n  voxel_sise: 0.05\n");
  FeatureParams f;
  try {
    loadFeatureParamsFile(f, path);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("features.voxel_sise"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadFeatureParamsFile(f, dir.file("missing.yaml")), std::runtime_error);
}

TEST(Assignments, GoToTheRightParameterSet) {
  MacParams mac;
  FeatureParams f;
  applyAssignment(mac, f, "features.voxel_size=0.3");
  applyAssignment(mac, f, "graph.t_cmp=0.9");
  applyAssignment(mac, f, "features.ratio_test=0.8");
  EXPECT_DOUBLE_EQ(f.voxel_size, 0.3);
  EXPECT_DOUBLE_EQ(f.ratio_test, 0.8);
  EXPECT_DOUBLE_EQ(mac.graph.t_cmp, 0.9);
  EXPECT_THROW(applyAssignment(mac, f, "features.voxel_size"), std::invalid_argument);  // no '='
  EXPECT_THROW(applyAssignment(mac, f, "features.nonsense=1"), std::invalid_argument);  // unknown
  EXPECT_THROW(applyAssignment(mac, f, "features.mutual_filter=maybe"), std::invalid_argument);
  // A negative count would wrap to a huge size_t and pass every range check.
  EXPECT_THROW(applyAssignment(mac, f, "features.max_correspondences=-1"), std::invalid_argument);
  EXPECT_THROW(applyAssignment(mac, f, "cliques.max_cliques=2.5"), std::invalid_argument);
}

}  // namespace
}  // namespace mac_registration
