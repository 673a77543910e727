// mac_register as a user runs it: exit status 0 / 1 / 2 and the reason on stderr.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "cli_run.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

using test::CliRun;
using test::runTool;
using test::TempDir;

CliRun run(const std::string& arguments) { return runTool(MAC_REGISTER_BIN, arguments); }

std::string dataPath(const std::string& name) { return std::string(MAC_TEST_DATA_DIR) + "/" + name; }
std::string demoDataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(MacRegisterCli, BadArgumentsExitTwoWithUsage) {
  CliRun r = run("");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "usage:")) << r.output;
  r = run("--correspondences " + dataPath("redkitchen_24_59/correspondences.txt") +
          " --set graph.t_cmpp=0.9");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "graph.t_cmpp")) << r.output;
  r = run("--frobnicate");
  EXPECT_EQ(r.status, 2);
}

TEST(MacRegisterCli, MissingAndCorruptCorrespondenceFilesExitTwo) {
  TempDir dir;
  CliRun r = run("--correspondences " + dir.file("nothing.txt"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, dir.file("nothing.txt"))) << r.output;
  r = run("--correspondences " + dir.write("bad.txt", "1 2 3 4 5 six\n"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "bad.txt:1")) << r.output;
}

TEST(MacRegisterCli, AFailedRegistrationExitsOneWithTheReason) {
  TempDir dir;
  CliRun r = run("--correspondences " + dir.write("two.txt", "0 0 0 1 1 1\n1 0 0 2 1 1\n"));
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(contains(r.output, "registration failed")) << r.output;
  EXPECT_TRUE(contains(r.output, "at least 3")) << r.output;
}

TEST(MacRegisterCli, RealCorrespondencesRegisterAndWriteTheTransform) {
  TempDir dir;
  const CliRun r = run("--correspondences " + dataPath("redkitchen_24_59/correspondences.txt") +
                       " --config " + MAC_CONFIG_DIR + "/indoor_rgbd.yaml --out " + dir.file("T.txt"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "T_target_source:"));
  const Eigen::Isometry3d truth = readTransformFile(dataPath("redkitchen_24_59/T_target_source_gt.txt"));
  const Eigen::Isometry3d estimate = readTransformFile(dir.file("T.txt"));
  EXPECT_LT(rotationErrorDeg(estimate, truth), 15.0);  // the 3DMatch criterion
  EXPECT_LT(translationError(estimate, truth), 0.30);
}

#ifdef MAC_REGISTRATION_WITH_FEATURES
TEST(MacRegisterCli, CloudsRegisterAndPrintTheFrontEnd) {
  TempDir dir;
  const CliRun r =
      run(demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd") + " " +
          demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd") + " --config " + MAC_CONFIG_DIR +
          "/indoor_rgbd.yaml --out " + dir.file("T.txt") + " --save-correspondences " + dir.file("c.txt"));
  ASSERT_EQ(r.status, 0) << r.output;
  // The indoor preset gives d_cmp in metres, so the resolution is not estimated.
  EXPECT_TRUE(contains(r.output, "front end: resolution not estimated")) << r.output;
  const Eigen::Isometry3d truth = readTransformFile(demoDataPath("redkitchen_4_0/T_target_source_gt.txt"));
  const Eigen::Isometry3d estimate = readTransformFile(dir.file("T.txt"));
  EXPECT_LT(rotationErrorDeg(estimate, truth), 15.0);
  EXPECT_LT(translationError(estimate, truth), 0.30);
  EXPECT_GT(readCorrespondencesFile(dir.file("c.txt")).size(), 1000u);
}

// A SLAM pipeline's header, WIDTH 0 HEIGHT 0 with POINTS N: read and registered, the fault named on stderr.
TEST(MacRegisterCli, APcdWithAnEmptyGridRegistersWithAWarning) {
  TempDir dir;
  std::ifstream in(demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string grid = "WIDTH 13555\nHEIGHT 1\n";
  ASSERT_NE(bytes.find(grid), std::string::npos);
  const std::string target =
      dir.write("slam.pcd", bytes.replace(bytes.find(grid), grid.size(), "WIDTH 0\nHEIGHT 0\n"));
  const CliRun r = run(demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd") + " " + target + " --config " +
                       MAC_CONFIG_DIR + "/indoor_rgbd.yaml");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "mac_register: warning: cloud '" + target +
                                     "': its header says WIDTH 0 HEIGHT 0 but POINTS 13555"))
      << r.output;
}

// Object scale with one setting: the Stanford bunny scans (15 cm) with the object preset, whose voxel size
// and distances are auto. The ground truth is Stanford's own alignment (0.33 mm median residual).
TEST(MacRegisterCli, TheBunnyRegistersAndVerifiesWithTheObjectPreset) {
  TempDir dir;
  const CliRun r =
      run(demoDataPath("bunny/stanford_bun045.ply") + " " + demoDataPath("bunny/stanford_bun000.ply") +
          " --config " + MAC_CONFIG_DIR + "/object_scan.yaml --out " + dir.file("T.txt"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "status: success")) << r.output;
  const Eigen::Isometry3d truth = readTransformFile(demoDataPath("bunny/T_target_source_gt.txt"));
  const Eigen::Isometry3d estimate = readTransformFile(dir.file("T.txt"));
  // A few keypoint spacings (2.6 mm) of the truth: the refinement's residual, not a coarse pose.
  EXPECT_LT(rotationErrorDeg(estimate, truth), 2.0);
  EXPECT_LT(translationError(estimate, truth), 0.005);
  // The same pair with the indoor preset's 5 cm voxels is a handful of keypoints: scale is what decides.
  const CliRun indoor =
      run(demoDataPath("bunny/stanford_bun045.ply") + " " + demoDataPath("bunny/stanford_bun000.ply") +
          " --config " + MAC_CONFIG_DIR + "/indoor_rgbd.yaml");
  EXPECT_NE(indoor.status, 0) << indoor.output;
}

TEST(MacRegisterCli, CloudsThatDoNotOverlapExitOneAndSayWhy) {
  // redkitchen fragments 21 and 0: 1.4 % overlap. MAC finds a transform; the verification refuses it.
  TempDir dir;
  const CliRun r = run(dataPath("redkitchen_21/cloud_bin_21.pcd") + " " +
                       demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd") + " --config " + MAC_CONFIG_DIR +
                       "/indoor_rgbd.yaml --out " + dir.file("T.txt"));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "registration failed: unverified: confidence")) << r.output;
  EXPECT_TRUE(contains(r.output, "verification.min_confidence")) << r.output;
  EXPECT_TRUE(contains(r.output, "T_target_source (unverified")) << r.output;
  EXPECT_TRUE(contains(r.output, "verification: confidence")) << r.output;
  EXPECT_TRUE(contains(r.output, "inliers by chance")) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("T.txt")));  // no transform to act on
}

TEST(MacRegisterCli, MissingAndCorruptCloudsExitTwoNamingTheFile) {
  TempDir dir;
  const std::string good = demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd");
  CliRun r = run(dir.file("absent.pcd") + " " + good);
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, dir.file("absent.pcd")) && contains(r.output, "no such file")) << r.output;
  r = run(good + " " + dir.write("corrupt.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 9\n"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "corrupt.ply")) << r.output;
  r = run(dir.write("garbage.pcd", "not a cloud\n") + " " + good);  // PCL alone would crash on it
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "garbage.pcd")) << r.output;
  r = run(good + " " + dir.write("scan.bin", std::string(17, 'x')));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "scan.bin")) << r.output;
  r = run(good);  // one cloud only
  EXPECT_EQ(r.status, 2);
  r = run(good + " " + good + " --set features.voxel_size=-1");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "features.voxel_size")) << r.output;
}

// Each of these used to crash mac_register (SIGSEGV in PCL's reader, SIGABRT in FLANN), exhaust memory,
// or exit 0 after a warning; now each exits 2 naming the file and the reason.
TEST(MacRegisterCli, MalformedCloudFilesExitTwoNamingTheFileAndTheReason) {
  TempDir dir;
  const std::string good = demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd");
  const std::string fields = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  const std::string three = fields + "WIDTH 3\nHEIGHT 1\nPOINTS 3\n";
  const struct {
    std::string name, content, reason;
  } cases[] = {
      {"keyword.pcd", "RANGE 10\n" + three + "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n",
       "unknown header line 1 'RANGE 10'"},
      {"malformed.pcd", three + "DATA ascii\n1 2 3\n4 5\n7 8 9\n", "line 10 holds 2 values, not 3"},
      {"planted.pcd", three + "DATA ascii\n1 2 3\n4 5 6\n7 8 3e38\n", "point 2 has z = 3e+38 m"},
      {"wide.pcd",
       fields + "WIDTH 2000000000\nHEIGHT 1\nPOINTS 2000000000\nDATA binary\n" + std::string(36, '\0'),
       "need 24000000000 bytes"},
      {"huge.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n" +
           std::string(36, '\0'),
       "need at least 12000000000 bytes"},
  };
  for (const auto& c : cases) {
    const CliRun r = run(dir.write(c.name, c.content) + " " + good);
    EXPECT_EQ(r.status, 2) << c.name << ": " << r.output;
    EXPECT_TRUE(contains(r.output, dir.file(c.name)) && contains(r.output, c.reason))
        << c.name << ": " << r.output;
  }
}
#else
TEST(MacRegisterCli, CoreOnlyBuildRefusesCloudsWithTheReason) {
  const CliRun r = run(demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd") + " " +
                       demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "no PCL front end")) << r.output;
}
#endif

}  // namespace
}  // namespace mac_registration
