// mac_relocalize as a user runs it: exit status 0 / 1 / 2, the pose written to --out, the reason on stderr.
#include <gtest/gtest.h>

#include <fstream>
#include <iomanip>
#include <string>

#include "cli_run.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

using test::CliRun;
using test::runTool;
using test::TempDir;

CliRun run(const std::string& arguments) { return runTool(MAC_RELOCALIZE_BIN, arguments); }

std::string dataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }
const std::string kPreset = " --config " + std::string(MAC_CONFIG_DIR) + "/map_relocalization.yaml";

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(MacRelocalizeCli, BadArgumentsExitTwo) {
  CliRun r = run("");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "usage:")) << r.output;
  r = run(dataPath("lidar/lidar_target_251370668.pcd") + " " + dataPath("lidar/lidar_source_251371071.pcd") +
          " --set relocalization.max_candidates=0");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "relocalization.max_candidates")) << r.output;
  TempDir dir;
  r = run(dir.file("no_map.pcd") + " " + dataPath("lidar/lidar_source_251371071.pcd"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "no_map.pcd")) << r.output;
  // A map's keypoint spacing is given, not derived from its extent.
  r = run(dataPath("lidar/lidar_target_251370668.pcd") + " " + dataPath("lidar/lidar_source_251371071.pcd") +
          kPreset + " --set features.voxel_size=auto");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "voxel_size")) << r.output;
}

TEST(MacRelocalizeCli, AScanOfTheMappedPlaceIsLocalized) {
  TempDir dir;
  const CliRun r =
      run(dataPath("lidar/lidar_target_251370668.pcd") + " " + dataPath("lidar/lidar_source_251371071.pcd") +
          kPreset + " --out " + dir.file("T.txt"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "T_map_query:")) << r.output;
  EXPECT_TRUE(contains(r.output, "places (best-ranked first):")) << r.output;
  EXPECT_TRUE(contains(r.output, "described in")) << r.output;
  const Eigen::Isometry3d written = readTransformFile(dir.file("T.txt"));
  const Eigen::Isometry3d reference =
      readTransformFile(dataPath("lidar/lidar_T_target_source_reference.txt"));
  EXPECT_LT(rotationErrorDeg(written, reference), 1.0);
  EXPECT_LT(translationError(written, reference), 0.2);
}

// The map in UTM coordinates, stored in float64 as surveyed maps are: read in double around a local origin,
// the pose comes back in the file's coordinates.
TEST(MacRelocalizeCli, AMapInGlobalCoordinatesAnswersInThem) {
  TempDir dir;
  const Eigen::Vector3d utm(512345.678, 4712345.678, 250.1);
  const PointCloud::Ptr scan = loadCloud(dataPath("lidar/lidar_target_251370668.pcd"));
  {
    std::ofstream pcd(dir.file("utm.pcd"));
    pcd << "VERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << scan->size()
        << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << scan->size() << "\nDATA ascii\n"
        << std::setprecision(12);
    for (const auto& p : *scan) pcd << p.x + utm.x() << " " << p.y + utm.y() << " " << p.z + utm.z() << "\n";
  }
  const CliRun r = run(dir.file("utm.pcd") + " " + dataPath("lidar/lidar_source_251371071.pcd") + kPreset +
                       " --out " + dir.file("T.txt"));
  ASSERT_EQ(r.status, 0) << r.output;
  Eigen::Isometry3d expected = readTransformFile(dataPath("lidar/lidar_T_target_source_reference.txt"));
  expected.pretranslate(utm);
  const Eigen::Isometry3d written = readTransformFile(dir.file("T.txt"));
  EXPECT_LT(rotationErrorDeg(written, expected), 1.0);
  EXPECT_LT(translationError(written, expected), 0.2);
}

// Real data: a drive through a campus junction minutes after it was mapped is found; a drive elsewhere on the
// campus, 170 m from anything mapped, is not.
TEST(MacRelocalizeCli, ACampusDriveIsFoundInItsMapAndOneElsewhereIsNot) {
  TempDir dir;
  const std::string map = dataPath("nclt_campus/map.pcd");
  CliRun r =
      run(map + " " + dataPath("nclt_campus/query_window.pcd") + kPreset + " --out " + dir.file("T.txt"));
  ASSERT_EQ(r.status, 0) << r.output;
  const Eigen::Isometry3d truth = readTransformFile(dataPath("nclt_campus/T_map_query.txt"));
  const Eigen::Isometry3d written = readTransformFile(dir.file("T.txt"));
  // The benchmark's criterion (the ground truth is the run's own optimization, good to a few decimetres).
  EXPECT_LT(rotationErrorDeg(written, truth), 5.0);
  EXPECT_LT(translationError(written, truth), 1.0);
  r = run(map + " " + dataPath("nclt_campus/unmapped_query_window.pcd") + kPreset);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "not localized")) << r.output;
}

TEST(MacRelocalizeCli, AQueryTheMapCannotPlaceExitsOneAndWritesNothing) {
  // A 3 m room against a street: at 0.5 m voxels it holds a few dozen keypoints and matches nowhere.
  TempDir dir;
  const CliRun r =
      run(dataPath("lidar/lidar_target_251370668.pcd") + " " +
          dataPath("redkitchen_4_0/target_cloud_bin_0.pcd") + kPreset + " --out " + dir.file("T.txt"));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "not localized")) << r.output;
  EXPECT_TRUE(contains(r.output, "not verified")) << r.output;
  EXPECT_FALSE(std::ifstream(dir.file("T.txt")).good());
}

}  // namespace
}  // namespace mac_registration
