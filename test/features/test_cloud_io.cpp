// loadCloud on the three formats, and its errors: each names the file and what is wrong with it.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <cstring>
#include <string>

#include "mac_registration/features/cloud_registration.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

using test::TempDir;

PointCloud threePoints() {
  PointCloud cloud;
  cloud.push_back(pcl::PointXYZ(1.0f, 2.0f, 3.0f));
  cloud.push_back(pcl::PointXYZ(-4.0f, 5.5f, 6.0f));
  cloud.push_back(pcl::PointXYZ(7.0f, -8.0f, 9.25f));
  return cloud;
}

void expectThreePoints(const PointCloud& cloud) {
  const PointCloud expected = threePoints();
  ASSERT_EQ(cloud.size(), expected.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_FLOAT_EQ(cloud[i].x, expected[i].x);
    EXPECT_FLOAT_EQ(cloud[i].y, expected[i].y);
    EXPECT_FLOAT_EQ(cloud[i].z, expected[i].z);
  }
}

// Expects loadCloud(path) to throw std::runtime_error whose message holds the path and `reason`.
void expectLoadError(const std::string& path, const std::string& reason) {
  try {
    loadCloud(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

TEST(LoadCloud, ReadsPcdAsciiAndBinary) {
  TempDir dir;
  pcl::io::savePCDFileASCII(dir.file("a.pcd"), threePoints());
  pcl::io::savePCDFileBinary(dir.file("b.PCD"), threePoints());  // extension case does not matter
  expectThreePoints(*loadCloud(dir.file("a.pcd")));
  expectThreePoints(*loadCloud(dir.file("b.PCD")));
}

TEST(LoadCloud, ReadsPly) {
  TempDir dir;
  pcl::io::savePLYFileBinary(dir.file("c.ply"), threePoints());
  expectThreePoints(*loadCloud(dir.file("c.ply")));
}

TEST(LoadCloud, ReadsKittiBinAndIgnoresIntensity) {
  TempDir dir;
  std::string bytes;
  for (const auto& p : threePoints()) {
    const float record[4] = {p.x, p.y, p.z, 0.5f};
    bytes.append(reinterpret_cast<const char*>(record), sizeof record);
  }
  expectThreePoints(*loadCloud(dir.write("000000.bin", bytes)));
}

TEST(LoadCloud, NamesMissingCorruptAndEmptyFiles) {
  TempDir dir;
  expectLoadError(dir.file("missing.pcd"), "no such file");
  // PCL 1.13 itself crashes on the first two and reads zeros for a missing field.
  expectLoadError(dir.write("garbage.pcd", "this is not a point cloud\n"), "not a valid .pcd");
  expectLoadError(dir.write("empty.pcd", ""), "not a valid .pcd");
  expectLoadError(dir.write("no_z.pcd",
                            "VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nWIDTH 1\nHEIGHT 1\n"
                            "POINTS 1\nDATA ascii\n1 2\n"),
                  "no FIELDS x y z");
  expectLoadError(dir.write("short.pcd",
                            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\n"
                            "HEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n"),
                  "not a valid .pcd");
  expectLoadError(dir.write("garbage.ply", "ply\nformat nonsense\n"), "not a valid .ply");
  expectLoadError(dir.write("faces.ply",
                            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                            "element face 0\nproperty float z\nend_header\n1 2\n"),
                  "no vertex element with x, y and z");
  expectLoadError(dir.write("short.bin", std::string(20, '\0')), "16-byte");
  expectLoadError(dir.write("empty.bin", ""), "no points");
  expectLoadError(dir.write("cloud.xyz", "1 2 3\n"), "unknown extension");
}

TEST(LoadCloud, ReadsTheShippedRealPair) {
  const PointCloud::Ptr cloud =
      loadCloud(std::string(MAC_TEST_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd");
  EXPECT_EQ(cloud->size(), 13622u);
}

}  // namespace
}  // namespace mac_registration
