// loadCloud on the three formats, and its errors: each names the file and what is wrong with it; and
// loadLocalCloud on maps in global coordinates.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

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
// header is refused.
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
  // Integer coordinates are legal in the format: read, as metres like any other.
  expectThreePoints(*loadCloud(dir.write("int_x.pcd", replaced(asciiPcd(""), "TYPE F F F", "TYPE I F F"))));
  expectLoadError(dir.write("count_x.pcd", replaced(asciiPcd("", "1 0 2 3\n-4 0 5.5 6\n7 0 -8 9.25\n"),
                                                    "COUNT 1 1 1", "COUNT 2 1 1")),
                  "field 'x' holds COUNT 2 values, not one coordinate");
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
  expectThreePoints(*loadCloud(dir.write(
      "int_x.ply", replaced(plyHeader("ascii", "3"), "float x", "int x") + "1 2 3\n-4 5.5 6\n7 -8 9.25\n")));
  expectLoadError(dir.write("list_x.ply", replaced(plyHeader("ascii", "3"), "float x", "list uchar float x") +
                                              "1 1 2 3\n1 -4 5.5 6\n1 7 -8 9.25\n"),
                  "no vertex element with x, y and z");
  expectLoadError(
      dir.write("float_length.ply", plyHeader("ascii", "1", "property list float int i\n") + "1 2 3 0\n"),
      "list 'i' has a length of type 'float', not an integer");
  expectLoadError(dir.write("dup.ply", plyHeader("ascii", "3", "property float x\n") + "1 2 3\n"),
                  "two properties named 'x'");
  expectLoadError(
      dir.write("no_format.ply", replaced(plyHeader("ascii", "1"), "format ascii 1.0\n", "") + "1 2 3\n"),
      "no format line");
}

// A Stanford 3D Scanning Repository range scan (bun045.ply, dragon...): after the vertices, one list a cell
// of the scanner's grid, empty or naming the vertex seen there. PCL read the grid as an organised cloud.
std::string rangeScanPly(bool obj_info) {
  return std::string("ply\nformat ascii 1.0\n") +
         (obj_info ? "obj_info is_cyberware_data 0\nobj_info num_cols 3\nobj_info num_rows 2\n" : "") +
         "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element range_grid 6\nproperty list uchar int vertex_indices\nend_header\n"
         "1 2 3\n-4 5.5 6\n7 -8 9.25\n1 0\n0\n0\n1 1\n0\n1 2\n";
}

TEST(LoadCloud, ReadsTheVerticesOfStanfordRangeScans) {
  TempDir dir;
  expectThreePoints(*loadCloud(dir.write("bun045.ply", rangeScanPly(true))));
  expectThreePoints(*loadCloud(dir.write("no_obj_info.ply", rangeScanPly(false))));
  // The grid disagreeing with its header is still refused: a list longer than the data, a length not a
  // number.
  const std::string scan = rangeScanPly(true);
  expectLoadError(dir.write("cut_grid.ply", scan.substr(0, scan.size() - 6)),
                  "its data ends inside element 'range_grid' (5 of 6) (truncated?)");
  expectLoadError(dir.write("long_list.ply", replaced(rangeScanPly(true), "1 2\n", "9 2\n")),
                  "its data ends inside element 'range_grid' (6 of 6)");
  expectLoadError(dir.write("bad_length.ply", replaced(rangeScanPly(true), "1 1\n", "1.5 1\n")),
                  "line 19: list length '1.5' is not a whole number");
}

// `value`'s bytes in the given byte order (the tests run on little-endian machines).
template <typename T>
std::string bytesOf(T value, bool big_endian = false) {
  std::string bytes(reinterpret_cast<const char*>(&value), sizeof value);
  if (big_endian) std::reverse(bytes.begin(), bytes.end());
  return bytes;
}

// Coordinates that need their decoding right: a fraction, negatives, one beyond what int16 holds.
const double kDoubles[3][3] = {{0.1, -2.5, 3.0}, {-40000.25, 5.5, 6.0}, {7.0, -8.0, 1e-3}};

void expectDoubles(const PointCloud& cloud) {
  ASSERT_EQ(cloud.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_FLOAT_EQ(cloud[i].x, float(kDoubles[i][0])) << i;
    EXPECT_FLOAT_EQ(cloud[i].y, float(kDoubles[i][1])) << i;
    EXPECT_FLOAT_EQ(cloud[i].z, float(kDoubles[i][2])) << i;
  }
}

// PCL's reader made every point the origin; Open3D writes double coordinates by default.
TEST(LoadCloud, ReadsDoublePrecisionPlyInEveryEncoding) {
  TempDir dir;
  const std::string header =
      "element vertex 3\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::ostringstream ascii;
  ascii.precision(17);
  for (const auto& p : kDoubles) ascii << p[0] << " " << p[1] << " " << p[2] << " 255\n";
  expectDoubles(
      *loadCloud(dir.write("ascii.ply", "ply\nformat ascii 1.0\n" + header + ascii.str() + "3 0 1 2\n")));
  for (const bool big_endian : {false, true}) {
    std::string body;
    for (const auto& p : kDoubles)
      body += bytesOf(p[0], big_endian) + bytesOf(p[1], big_endian) + bytesOf(p[2], big_endian) + "\xff";
    body += "\x03" + bytesOf(std::int32_t(0), big_endian) + bytesOf(std::int32_t(1), big_endian) +
            bytesOf(std::int32_t(2), big_endian);
    const std::string format = big_endian ? "binary_big_endian" : "binary_little_endian";
    expectDoubles(*loadCloud(dir.write(format + ".ply", "ply\nformat " + format + " 1.0\n" + header + body)));
  }
}

TEST(LoadCloud, ReadsBinaryPlyOfAnyNumericTypeAndListsBeforeTheVertices) {
  TempDir dir;
  // A list element before the vertices must be walked entry by entry to find where they start.
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement tag 2\nproperty list ushort char text\n"
      "element vertex 2\nproperty short x\nproperty uchar y\nproperty list uchar float normal\n"
      "property int z\nend_header\n";
  const std::string body = bytesOf(std::uint16_t(3), true) + "abc" + bytesOf(std::uint16_t(0), true) +
                           bytesOf(std::int16_t(-4), true) + "\xc8" + "\x01" + bytesOf(1.0f, true) +
                           bytesOf(std::int32_t(-70000), true) + bytesOf(std::int16_t(300), true) +
                           std::string(2, '\0') /* y 0, no normal */ + bytesOf(std::int32_t(9), true);
  const PointCloud::Ptr cloud = loadCloud(dir.write("mixed.ply", header + body));
  ASSERT_EQ(cloud->size(), 2u);
  EXPECT_EQ((*cloud)[0].x, -4.0f);
  EXPECT_EQ((*cloud)[0].y, 200.0f);
  EXPECT_EQ((*cloud)[0].z, -70000.0f);
  EXPECT_EQ((*cloud)[1].x, 300.0f);
  EXPECT_EQ((*cloud)[1].y, 0.0f);
  EXPECT_EQ((*cloud)[1].z, 9.0f);
  expectLoadError(dir.write("cut_list.ply", header + body.substr(0, body.size() - 6)),
                  "its data ends inside element 'vertex' (2 of 2)");
}

// A cloud of `points` with double x y z and a float intensity, as PCL's writers store it from PCLPointCloud2.
pcl::PCLPointCloud2 doubleCloud(const std::vector<Eigen::Vector3d>& points) {
  pcl::PCLPointCloud2 cloud;
  for (const char* name : {"x", "y", "z"}) {
    pcl::PCLPointField field;
    field.name = name;
    field.offset = std::uint32_t(8 * cloud.fields.size());
    field.datatype = pcl::PCLPointField::FLOAT64;
    field.count = 1;
    cloud.fields.push_back(field);
  }
  pcl::PCLPointField intensity;
  intensity.name = "intensity";
  intensity.offset = 24;
  intensity.datatype = pcl::PCLPointField::FLOAT32;
  intensity.count = 1;
  cloud.fields.push_back(intensity);
  cloud.point_step = 28;
  cloud.width = std::uint32_t(points.size());
  cloud.height = 1;
  cloud.row_step = cloud.point_step * cloud.width;
  for (const auto& p : points) {
    const std::string point = bytesOf(p.x()) + bytesOf(p.y()) + bytesOf(p.z()) + bytesOf(0.5f);
    cloud.data.insert(cloud.data.end(), point.begin(), point.end());
  }
  return cloud;
}

pcl::PCLPointCloud2 doubleCloud() {
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : kDoubles) points.emplace_back(p[0], p[1], p[2]);
  return doubleCloud(points);
}

TEST(LoadCloud, ReadsDoublePrecisionPcdInEveryEncoding) {
  TempDir dir;
  pcl::PCDWriter writer;
  const Eigen::Vector4f origin(1.0f, 2.0f, 3.0f, 0.0f);
  const Eigen::Quaternionf orientation(0.5f, 0.5f, 0.5f, 0.5f);
  writer.writeASCII(dir.file("a.pcd"), doubleCloud(), origin, orientation, 17);
  writer.writeBinary(dir.file("b.pcd"), doubleCloud(), origin, orientation);
  writer.writeBinaryCompressed(dir.file("c.pcd"), doubleCloud(), origin, orientation);
  for (const char* name : {"a.pcd", "b.pcd", "c.pcd"}) {
    SCOPED_TRACE(name);
    const PointCloud::Ptr cloud = loadCloud(dir.file(name));
    expectDoubles(*cloud);
    // VIEWPOINT is where the verification puts the sensor.
    EXPECT_EQ(cloud->sensor_origin_, origin);
    EXPECT_EQ(cloud->sensor_orientation_.coeffs(), orientation.coeffs());
  }
}

TEST(LoadCloud, KeepsAnOrganisedPcdsGridAndItsNans) {
  TempDir dir;
  PointCloud grid(2, 3, pcl::PointXYZ(1.0f, 2.0f, 3.0f));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  grid(1, 0) = pcl::PointXYZ(nan, nan, nan);
  grid(0, 2).z = nan;
  grid.is_dense = false;
  pcl::io::savePCDFileBinary(dir.file("b.pcd"), grid);
  pcl::PCDWriter().writeBinaryCompressed(dir.file("c.pcd"), grid);
  pcl::io::savePCDFileASCII(dir.file("a.pcd"), grid);
  for (const char* name : {"a.pcd", "b.pcd", "c.pcd"}) {
    SCOPED_TRACE(name);
    const PointCloud::Ptr cloud = loadCloud(dir.file(name));
    EXPECT_EQ(cloud->width, 2u);
    EXPECT_EQ(cloud->height, 3u);
    ASSERT_EQ(cloud->size(), 6u);
    EXPECT_FALSE(cloud->is_dense);
    EXPECT_TRUE(std::isnan((*cloud)(1, 0).x));
    EXPECT_TRUE(std::isnan((*cloud)(0, 2).z));
    EXPECT_EQ((*cloud)(0, 2).y, 2.0f);
    EXPECT_EQ((*cloud)(1, 2).x, 1.0f);
  }
}

// PCD v0.5 named only POINTS; older headers still (COLUMNS for FIELDS, no SIZE and TYPE: every field a
// float32) are read as PCL reads them.
TEST(LoadCloud, ReadsPcdVersion05WithoutAGrid) {
  TempDir dir;
  const std::string points = "POINTS 3\nDATA ascii\n1 2 3\n-4 5.5 6\n7 -8 9.25\n";
  std::vector<std::string> warnings;
  const PointCloud::Ptr cloud = loadCloud(
      dir.write("v05.pcd",
                "# .PCD v.5\nVERSION .5\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + points),
      &warnings);
  expectThreePoints(*cloud);
  EXPECT_EQ(cloud->width, 3u);
  EXPECT_EQ(cloud->height, 1u);
  EXPECT_TRUE(warnings.empty());
  expectThreePoints(*loadCloud(dir.write("columns.pcd", "VERSION .5\nCOLUMNS x y z\n" + points)));
  expectLoadError(dir.write("height.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nHEIGHT 1\n" + points),
                  "HEIGHT but no WIDTH line");
  expectLoadError(dir.write("no_grid.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nDATA ascii\n1 2 3\n"),
                  "no WIDTH or POINTS line");
}

// SLAM pipelines (the NCLT keyframes in ../shared) write WIDTH 0 HEIGHT 0 with POINTS N, binary_compressed
// x y z intensity; PCL refuses them ("HEIGHT given (0) but no WIDTH"), Open3D reads N unorganised points.
TEST(LoadCloud, ReadsAPcdWithAnEmptyGridAndWarnsOfIt) {
  TempDir dir;
  pcl::PointCloud<pcl::PointXYZI> scan;
  for (const auto& p : threePoints()) {
    pcl::PointXYZI point;
    point.x = p.x;
    point.y = p.y;
    point.z = p.z;
    point.intensity = 42.0f;
    scan.push_back(point);
  }
  pcl::PCDWriter().writeBinaryCompressed(dir.file("z.pcd"), scan);
  std::ifstream in(dir.file("z.pcd"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string path =
      dir.write("keyframe.pcd", replaced(replaced(bytes, "WIDTH 3", "WIDTH 0"), "HEIGHT 1", "HEIGHT 0"));
  std::vector<std::string> warnings;
  const PointCloud::Ptr cloud = loadCloud(path, &warnings);
  expectThreePoints(*cloud);
  EXPECT_EQ(cloud->width, 3u);
  EXPECT_EQ(cloud->height, 1u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "cloud '" + path +
                "': its header says WIDTH 0 HEIGHT 0 but POINTS 3 (WIDTH x HEIGHT should be POINTS); "
                "read as 3 unorganised points");
  expectThreePoints(*loadCloud(path));  // without a place for warnings
  // Other grids that disagree with POINTS stay refused: which of the two is right is unknown.
  expectLoadError(dir.write("grid.pcd", replaced(bytes, "WIDTH 3", "WIDTH 2")),
                  "WIDTH x HEIGHT = 2 x 1 is not POINTS 3");
}

// A finite double beyond float's range must not become an infinity, which the front end would drop.
TEST(LoadCloud, RefusesDoubleCoordinatesBeyondFloatsRange) {
  TempDir dir;
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
      "property double z\nend_header\n";
  expectLoadError(dir.write("far.ply", header + bytesOf(1.0) + bytesOf(-1e300) + bytesOf(1.0)),
                  "point 0 has y = -3.40282e+38 m, beyond the front end's bound");
}

TEST(LoadCloud, RefusesCompressedPcdsThatDoNotUnpack) {
  TempDir dir;
  pcl::PCDWriter().writeBinaryCompressed(dir.file("z.pcd"), threePoints());
  std::ifstream in(dir.file("z.pcd"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t data = bytes.find("binary_compressed\n") + 18;
  std::string corrupt = bytes;
  corrupt[data + 8] = '\xff';  // an LZF back reference before the start of the output
  expectLoadError(dir.write("corrupt.pcd", corrupt), "does not unpack to its 36 bytes");
  // A garbage size word must not allocate what it claims: 12 MB from 10 bytes is beyond LZF.
  const std::string header =
      "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000\nPOINTS 1000000\n"
      "DATA binary_compressed\n";
  expectLoadError(dir.write("claims.pcd", header + bytesOf(std::uint32_t(10)) +
                                              bytesOf(std::uint32_t(12000000)) + std::string(10, '\0')),
                  "claims 10 compressed bytes unpack to 12000000, more than LZF can");
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

// A map in UTM coordinates (zone 32T), about 10 km across, of five points whose medians are those of the
// first: eastings and northings float32 would round to 6.25 cm and 0.5 m, heights float32 holds.
const std::vector<Eigen::Vector3d> kUtmMap = {{512345.678, 4712345.678, 250.1},
                                              {517345.123, 4707345.987, 180.456},
                                              {508345.001, 4716345.999, 320.789},
                                              {512000.5, 4712400.25, 251.0},
                                              {513000.25, 4711000.125, 249.875}};
// The medians rounded to whole metres; the heights all lie within kLocalFrameBound and keep theirs.
const Eigen::Vector3d kUtmOrigin(512346.0, 4712346.0, 0.0);

// Expects the local cloud to be `points` in the frame of `origin`, to a millimetre.
void expectLocalPoints(const LocalCloud& local, const std::vector<Eigen::Vector3d>& points,
                       const Eigen::Vector3d& origin) {
  EXPECT_EQ(local.origin, origin);
  ASSERT_EQ(local.cloud->size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d restored = (*local.cloud)[i].getVector3fMap().cast<double>() + local.origin;
    EXPECT_LT((restored - points[i]).cwiseAbs().maxCoeff(), 1e-3)
        << i << ": " << restored.transpose() << " read, " << points[i].transpose() << " written";
  }
}

// The PLY of `points` with double x y z, in `format`.
std::string doublePly(const std::vector<Eigen::Vector3d>& points, const std::string& format) {
  std::string ply = "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(points.size()) +
                    "\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
  std::ostringstream ascii;
  ascii.precision(17);
  for (const auto& p : points) {
    if (format == "ascii")
      ascii << p.x() << " " << p.y() << " " << p.z() << "\n";
    else
      ply += bytesOf(p.x()) + bytesOf(p.y()) + bytesOf(p.z());
  }
  return ply + ascii.str();
}

TEST(LoadLocalCloud, ReadsAUtmMapInEveryDoubleEncodingToTheMillimetre) {
  TempDir dir;
  pcl::PCDWriter writer;
  writer.writeASCII(dir.file("a.pcd"), doubleCloud(kUtmMap), Eigen::Vector4f::Zero(),
                    Eigen::Quaternionf::Identity(), 17);
  writer.writeBinary(dir.file("b.pcd"), doubleCloud(kUtmMap));
  writer.writeBinaryCompressed(dir.file("c.pcd"), doubleCloud(kUtmMap));
  dir.write("a.ply", doublePly(kUtmMap, "ascii"));
  dir.write("b.ply", doublePly(kUtmMap, "binary_little_endian"));
  for (const char* name : {"a.pcd", "b.pcd", "c.pcd", "a.ply", "b.ply"}) {
    SCOPED_TRACE(name);
    std::vector<std::string> warnings;
    const LocalCloud local = loadLocalCloud(dir.file(name), &warnings);
    expectLocalPoints(local, kUtmMap, kUtmOrigin);
    EXPECT_TRUE(warnings.empty());
    EXPECT_TRUE(local.cloud->is_dense);
    // loadCloud keeps the file's frame, where the northings are beyond the coordinate bound.
    expectLoadError(dir.file(name),
                    "point 0 has y = 4.71235e+06 m, beyond the front end's bound of +-1e+06 m");
  }
}

// The sensor's position is a point of the map like the others: it moves into the local frame with them.
TEST(LoadLocalCloud, MovesTheViewpointIntoTheLocalFrame) {
  TempDir dir;
  pcl::PCDWriter().writeBinary(dir.file("b.pcd"), doubleCloud(kUtmMap));
  std::ifstream in(dir.file("b.pcd"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string path = dir.write("viewpoint.pcd", replaced(bytes, "VIEWPOINT 0 0 0 1 0 0 0",
                                                               "VIEWPOINT 512340.5 4712350.25 260 0 1 0 0"));
  const LocalCloud local = loadLocalCloud(path);
  expectLocalPoints(local, kUtmMap, kUtmOrigin);
  EXPECT_EQ(local.cloud->sensor_origin_, Eigen::Vector4f(-5.5f, 4.25f, 260.0f, 0.0f));
  EXPECT_EQ(local.cloud->sensor_orientation_.coeffs(), Eigen::Quaternionf(0.0f, 1.0f, 0.0f, 0.0f).coeffs());
}

// Below the bound float32 still spaces eastings 6.25 cm apart; the local frame keeps the millimetres.
TEST(LoadLocalCloud, KeepsTheMillimetresLoadCloudRoundsAway) {
  TempDir dir;
  const std::vector<Eigen::Vector3d> points = {{912345.03, 12.5, 3.0}, {912350.97, -20.25, 4.5}};
  const std::string path = dir.write("east.ply", doublePly(points, "binary_little_endian"));
  const PointCloud::Ptr global = loadCloud(path);
  EXPECT_GT(std::abs(double((*global)[0].x) - points[0].x()), 0.01);
  expectLocalPoints(loadLocalCloud(path), points, Eigen::Vector3d(912351.0, 0.0, 0.0));
}

// A cloud within kLocalFrameBound of its frame's origin keeps that frame: it reads as loadCloud reads it.
TEST(LoadLocalCloud, LeavesASmallCloudInItsFrame) {
  TempDir dir;
  PointCloud grid(2, 3, pcl::PointXYZ(1.0f, 2.0f, 3.0f));
  grid(1, 0) = pcl::PointXYZ(-9999.5f, 9999.75f, std::numeric_limits<float>::quiet_NaN());
  grid(0, 2) = pcl::PointXYZ(0.1f, -0.2f, 0.3f);
  grid.is_dense = false;
  pcl::io::savePCDFileBinary(dir.file("grid.pcd"), grid);
  std::string bin;
  for (const auto& p : threePoints()) {
    const float record[4] = {p.x, p.y, p.z, 0.5f};
    bin.append(reinterpret_cast<const char*>(record), sizeof record);
  }
  dir.write("scan.bin", bin);
  pcl::io::savePLYFileBinary(dir.file("c.ply"), threePoints());
  for (const char* name : {"grid.pcd", "scan.bin", "c.ply"}) {
    SCOPED_TRACE(name);
    const PointCloud::Ptr global = loadCloud(dir.file(name));
    const LocalCloud local = loadLocalCloud(dir.file(name));
    EXPECT_EQ(local.origin, Eigen::Vector3d::Zero());
    ASSERT_EQ(local.cloud->size(), global->size());
    for (std::size_t i = 0; i < global->size(); ++i) {
      const Eigen::Vector3f a = (*local.cloud)[i].getVector3fMap(), b = (*global)[i].getVector3fMap();
      EXPECT_TRUE(((a.array() == b.array()) || (a.array().isNaN() && b.array().isNaN())).all()) << i;
    }
    EXPECT_EQ(local.cloud->width, global->width);
    EXPECT_EQ(local.cloud->height, global->height);
    EXPECT_EQ(local.cloud->is_dense, global->is_dense);
    EXPECT_EQ(local.cloud->sensor_origin_, global->sensor_origin_);
  }
}

// A misdecoded value does not move the median: the bound names it, not the map's good points.
TEST(LoadLocalCloud, RefusesAMisdecodedCoordinateByName) {
  TempDir dir;
  std::vector<Eigen::Vector3d> points = kUtmMap;
  points[3].x() = 1e30;
  const std::string path = dir.write("garbage.ply", doublePly(points, "binary_little_endian"));
  try {
    loadLocalCloud(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(
        std::string(e.what()).find("cannot use cloud '" + path +
                                   "': point 3 has x = 1e+30 m, beyond the front end's bound of +-1e+06 m"),
        std::string::npos)
        << e.what();
  }
}

TEST(LoadCloud, ReadsTheShippedRealPair) {
  const PointCloud::Ptr cloud =
      loadCloud(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd");
  EXPECT_EQ(cloud->size(), 13622u);
}

}  // namespace
}  // namespace mac_registration
