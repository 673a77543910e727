// loadCloud on the three formats, and its errors: each names the file and what is wrong with it.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "mac_registration/features/cloud_filtering.hpp"
#include "mac_registration/features/cloud_io.hpp"
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

TEST(LoadCloud, ReadsEveryEncodingPclWrites) {
  TempDir dir;
  pcl::PCDWriter writer;
  writer.writeBinaryCompressed(dir.file("z.pcd"), threePoints());
  expectThreePoints(*loadCloud(dir.file("z.pcd")));
  pcl::io::savePLYFileASCII(dir.file("a.ply"), threePoints());
  expectThreePoints(*loadCloud(dir.file("a.ply")));
  // Comments, COUNT and VIEWPOINT left out, CRLF line ends: still a valid header.
  expectThreePoints(*loadCloud(dir.write("minimal.pcd",
                                         "# hand-written\r\nFIELDS x y z\r\nSIZE 4 4 4\r\nTYPE F F F\r\n"
                                         "WIDTH 3\r\nHEIGHT 1\r\nPOINTS 3\r\nDATA ascii\r\n"
                                         "1 2 3\r\n-4 5.5 6\r\n7 -8 9.25\r\n")));
}

// The PCD header of threePoints() in ascii, with `line` inserted before its DATA line.
std::string asciiPcd(const std::string& line, const std::string& data = "1 2 3\n-4 5.5 6\n7 -8 9.25\n") {
  return "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n"
         "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n" +
         line + "DATA ascii\n" + data;
}

// Replaces the first `old` in `text` by `replacement`.
std::string replaced(std::string text, const std::string& old, const std::string& replacement) {
  const auto at = text.find(old);
  EXPECT_NE(at, std::string::npos) << old;
  return at == std::string::npos ? text : text.replace(at, old.size(), replacement);
}

// PCL 1.13 segfaults on an unknown header line and allocates what a garbage count asks for; every such
// header is refused before PCL reads the file.
TEST(LoadCloud, RefusesPcdHeadersPclWouldMisread) {
  TempDir dir;
  expectThreePoints(*loadCloud(dir.write("good.pcd", asciiPcd(""))));
  expectLoadError(dir.write("unknown.pcd", asciiPcd("COLOR red\n")), "unknown header line 10 'COLOR red'");
  expectLoadError(dir.write("twice.pcd", asciiPcd("WIDTH 3\n")), "WIDTH appears twice");
  expectLoadError(dir.write("dup_x.pcd", replaced(asciiPcd(""), "FIELDS x y z", "FIELDS x x z")),
                  "two fields named 'x'");
  expectLoadError(dir.write("sizes.pcd", replaced(asciiPcd(""), "SIZE 4 4 4", "SIZE 4 4")),
                  "3 FIELDS but 2 SIZE");
  expectLoadError(dir.write("size3.pcd", replaced(asciiPcd(""), "SIZE 4 4 4", "SIZE 4 3 4")), "SIZE 3");
  expectLoadError(dir.write("type.pcd", replaced(asciiPcd(""), "TYPE F F F", "TYPE F Q F")), "TYPE 'Q'");
  expectLoadError(dir.write("int_x.pcd", replaced(asciiPcd(""), "TYPE F F F", "TYPE I F F")),
                  "field 'x' is not one float");
  expectLoadError(dir.write("count0.pcd", replaced(asciiPcd(""), "COUNT 1 1 1", "COUNT 1 0 1")), "COUNT 0");
  expectLoadError(dir.write("negative.pcd", replaced(asciiPcd(""), "WIDTH 3", "WIDTH -3")),
                  "WIDTH value '-3' is not a whole number");
  expectLoadError(dir.write("huge.pcd", replaced(asciiPcd(""), "WIDTH 3", "WIDTH 99999999999")),
                  "WIDTH value '99999999999'");
  expectLoadError(dir.write("points.pcd", replaced(asciiPcd(""), "POINTS 3", "POINTS 4")), "is not POINTS 4");
  expectLoadError(
      dir.write("viewpoint.pcd", replaced(asciiPcd(""), "VIEWPOINT 0 0 0 1 0 0 0", "VIEWPOINT 0")),
      "VIEWPOINT needs 7 numbers");
  expectLoadError(dir.write("data.pcd", replaced(asciiPcd(""), "DATA ascii", "DATA zipped")),
                  "DATA 'zipped'");
  expectLoadError(dir.write("no_type.pcd", replaced(asciiPcd(""), "TYPE F F F\n", "")), "no TYPE line");
  expectLoadError(dir.write("binary_junk.pcd", std::string(100000, '\x01')), "longer than 65536 bytes");
}

// PCL's ascii reader only warns ("possibly malformed") about these and fills in zeros.
TEST(LoadCloud, RefusesPcdAsciiDataThatDisagreesWithItsHeader) {
  TempDir dir;
  expectLoadError(dir.write("short_line.pcd", asciiPcd("", "1 2 3\n-4 5.5\n7 -8 9.25\n")),
                  "line 12 holds 2 values, not 3");
  expectLoadError(dir.write("long_line.pcd", asciiPcd("", "1 2 3 4\n-4 5.5 6\n7 -8 9.25\n")),
                  "line 11 holds 4 values, not 3");
  expectLoadError(dir.write("word.pcd", asciiPcd("", "1 2 3\n-4 five 6\n7 -8 9.25\n")),
                  "'five' is not a number");
  expectLoadError(dir.write("more.pcd", asciiPcd("", "1 2 3\n-4 5.5 6\n7 -8 9.25\n0 0 0\n")),
                  "more data lines than its 3 POINTS");
  expectLoadError(dir.write("fewer.pcd", asciiPcd("", "1 2 3\n")), "POINTS 3 but 1 data lines");
}

TEST(LoadCloud, RefusesBinaryPcdsShorterThanTheirPoints) {
  TempDir dir;
  pcl::io::savePCDFileBinary(dir.file("b.pcd"), threePoints());
  std::ifstream in(dir.file("b.pcd"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  expectLoadError(dir.write("cut.pcd", bytes.substr(0, bytes.size() - 5)), "need 36 bytes of binary data");
  // A garbage WIDTH: PCL would try to allocate 2^31 points (std::bad_alloc or a crash).
  expectLoadError(dir.write("wide.pcd", replaced(replaced(bytes, "WIDTH 3", "WIDTH 2147483647"), "POINTS 3",
                                                 "POINTS 2147483647")),
                  "need 25769803764 bytes");

  pcl::PCDWriter writer;
  writer.writeBinaryCompressed(dir.file("z.pcd"), threePoints());
  std::ifstream zin(dir.file("z.pcd"), std::ios::binary);
  const std::string zbytes((std::istreambuf_iterator<char>(zin)), std::istreambuf_iterator<char>());
  expectLoadError(dir.write("zcut.pcd", zbytes.substr(0, zbytes.size() - 3)), "compressed bytes");
  expectLoadError(
      dir.write("zwide.pcd", replaced(replaced(zbytes, "WIDTH 3", "WIDTH 5"), "POINTS 3", "POINTS 5")),
      "unpacks to 36 bytes");
  expectLoadError(dir.write("zempty.pcd", zbytes.substr(0, zbytes.find("binary_compressed") + 18)),
                  "without its two size words");
}

// Finite but absurd coordinates would abort the process in FLANN's kd-tree (float distances overflow).
TEST(LoadCloud, RefusesCoordinatesBeyondTheBoundNamingTheFileAndTheBound) {
  TempDir dir;
  PointCloud planted = threePoints();
  planted[2].y = 3e38f;
  pcl::io::savePCDFileBinary(dir.file("planted.pcd"), planted);
  expectLoadError(dir.file("planted.pcd"),
                  "point 2 has y = 3e+38 m, beyond the front end's bound of +-1e+06 m");
  std::string bytes;
  for (const float v : {1.0f, 2.0f, 3.0f, 0.0f, -1e20f, 0.0f, 0.0f, 0.0f})
    bytes.append(reinterpret_cast<const char*>(&v), 4);
  expectLoadError(dir.write("far.bin", bytes), "point 1 has x = -1e+20 m");
  PointCloud within = threePoints();
  within[0].x = float(kMaxAbsCoordinate);  // the bound itself is allowed
  pcl::io::savePCDFileBinary(dir.file("within.pcd"), within);
  EXPECT_EQ(loadCloud(dir.file("within.pcd"))->size(), 3u);
}

std::string plyHeader(const std::string& format, const std::string& vertices, const std::string& extra = "") {
  return "ply\nformat " + format + " 1.0\ncomment made by hand\nelement vertex " + vertices +
         "\nproperty float x\nproperty float y\nproperty float z\n" + extra + "end_header\n";
}

TEST(LoadCloud, RefusesPlyFilesPclWouldMisreadWithTheReason) {
  TempDir dir;
  expectThreePoints(
      *loadCloud(dir.write("good.ply", plyHeader("ascii", "3") + "1 2 3\n-4 5.5 6\n7 -8 9.25\n")));
  // PCL: "not a valid .ply file" with no reason, or an allocation of a garbage count.
  expectLoadError(
      dir.write("cut.ply", plyHeader("binary_little_endian", "9") + std::string(12, '\0')),
      "(9 vertices of 12 bytes, ...) need at least 108 bytes after the header, the file holds 12");
  expectLoadError(
      dir.write("huge.ply", plyHeader("binary_little_endian", "2000000000") + std::string(12, '\0')),
      "need at least 24000000000 bytes");
  expectLoadError(dir.write("short.ply", plyHeader("ascii", "3") + "1 2 3\n-4 5.5\n"),
                  "need at least 9 ascii values, it holds 5");
  expectLoadError(dir.write("word.ply", plyHeader("ascii", "3") + "1 2 3\n-4 five 6\n7 -8 9.25\n"),
                  "'five' is not a number");
  expectLoadError(dir.write("count.ply", plyHeader("ascii", "-1") + "1 2 3\n"), "needs a name and a count");
  expectLoadError(dir.write("keyword.ply", plyHeader("ascii", "3", "colour red\n") + "1 2 3\n"),
                  "unknown header line 'colour red'");
  expectLoadError(dir.write("type.ply", plyHeader("ascii", "3", "property quad w\n") + "1 2 3\n"),
                  "unknown property type 'quad'");
  expectLoadError(dir.write("format.ply", plyHeader("binary_middle_endian", "3") + "1 2 3\n"),
                  "is not ascii, binary_little_endian or binary_big_endian 1.0");
  expectLoadError(dir.write("int_x.ply", replaced(plyHeader("ascii", "3"), "float x", "int x") + "1 2 3\n"),
                  "vertex property 'x' is int, not a float");
  expectLoadError(dir.write("dup.ply", plyHeader("ascii", "3", "property float x\n") + "1 2 3\n"),
                  "two properties named 'x'");
  expectLoadError(
      dir.write("no_format.ply", replaced(plyHeader("ascii", "1"), "format ascii 1.0\n", "") + "1 2 3\n"),
      "no format line");
}

// Expects loadCloud(path) to refuse the file naming `reason` in a short message of printable ASCII: a binary
// file's bytes echoed raw would garble the terminal that shows the message.
void expectPrintableLoadError(const std::string& path, const std::string& reason) {
  try {
    loadCloud(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    const auto raw =
        std::count_if(message.begin(), message.end(), [](unsigned char c) { return c < 0x20 || c >= 0x7f; });
    EXPECT_EQ(raw, 0) << "raw bytes in the message for " << path;
    if (raw > 0) return;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
    EXPECT_LT(message.size(), path.size() + 300) << message;  // the 5000-byte line is cut
  }
}

TEST(LoadCloud, ShowsBinaryBytesInItsMessagesEscapedOrSummarised) {
  TempDir dir;
  const std::string binary("\x89\x01\xff\x00\x1b\x02\x03\x04", 8);
  expectPrintableLoadError(dir.write("binary_line.pcd", asciiPcd(binary + "\n")),
                           "unknown header line 10 (8 bytes of binary data)");
  expectPrintableLoadError(dir.write("escape.pcd", asciiPcd("COLOR r\x1b[31med\n")),
                           "unknown header line 10 'COLOR r\\x1B[31med'");
  expectPrintableLoadError(dir.write("long.pcd", asciiPcd("COLOR " + std::string(5000, 'r') + "\n")),
                           "unknown header line 10 'COLOR rrr");
  expectPrintableLoadError(
      dir.write("binary_word.pcd", asciiPcd("", "1 2 3\n-4 \x01\x02\x03 6\n7 -8 9.25\n")),
      "line 12: (3 bytes of binary data) is not a number");
  expectPrintableLoadError(
      dir.write("binary_type.pcd", replaced(asciiPcd(""), "TYPE F F F", "TYPE F \x7f F")),
      "TYPE (1 byte of binary data) is not F, I or U");
  expectPrintableLoadError(dir.write("binary_line.ply", plyHeader("ascii", "3", binary + "\n") + "1 2 3\n"),
                           "unknown header line (8 bytes of binary data)");
  expectPrintableLoadError(
      dir.write("binary_word.ply", plyHeader("ascii", "3") + "1 2 3\n-4 5.25\xff 6\n7 -8 9.25\n"),
      "'5.25\\xFF' is not a number");
}

TEST(LoadCloud, ReadsTheShippedRealPair) {
  const PointCloud::Ptr cloud =
      loadCloud(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd");
  EXPECT_EQ(cloud->size(), 13622u);
}

}  // namespace
}  // namespace mac_registration
