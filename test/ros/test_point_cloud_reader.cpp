// toPointCloud, the one place a PointCloud2 from the outside is read, on every malformed layout the
// malformed-cloud rostest sends the node: each is refused with its reason, or decoded exactly.
#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "mac_registration/ros/conversions.hpp"
#include "xyz_cloud.hpp"

namespace mac_registration {
namespace {

const std::vector<Eigen::Vector3f> kPoints = {{1.0f, 2.0f, 3.0f}, {-4.0f, 5.5f, 6.0f}, {7.0f, -8.0f, 9.25f}};

using mac_registration::test::xyzCloud;

sensor_msgs::PointField* field(sensor_msgs::PointCloud2& msg, const std::string& name) {
  for (auto& f : msg.fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

// Expects toPointCloud to refuse `msg` with a reason containing `reason`.
void expectRefused(const sensor_msgs::PointCloud2& msg, const std::string& reason) {
  const CloudConversion c = toPointCloud(msg);
  EXPECT_FALSE(c.cloud) << "accepted; expected: " << reason;
  EXPECT_NE(c.error.find(reason), std::string::npos) << "'" << c.error << "' lacks '" << reason << "'";
}

void expectPoints(const CloudConversion& c, const std::vector<Eigen::Vector3f>& expected) {
  ASSERT_TRUE(c.cloud) << c.error;
  ASSERT_EQ(c.cloud->size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_TRUE((*c.cloud)[i].getVector3fMap() == expected[i]) << "point " << i;
}

TEST(PointCloudReader, ReadsAPaddedOrganizedLayout) {
  sensor_msgs::PointCloud2 msg;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2Fields(4, "intensity", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
                                sensor_msgs::PointField::FLOAT32, "x", 1, sensor_msgs::PointField::FLOAT32,
                                "y", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(4);
  msg.width = 2, msg.height = 2;
  msg.row_step = 2 * msg.point_step + 8;  // 8 bytes of padding after each row
  msg.data.assign(std::size_t(msg.row_step) * msg.height, 0);
  const std::vector<Eigen::Vector3f> points = {{1, 2, 3}, {4, 5, 6}, {7, 8, 9}, {10, 11, 12}};
  for (std::size_t i = 0; i < 4; ++i) {
    std::uint8_t* p = msg.data.data() + (i / 2) * msg.row_step + (i % 2) * msg.point_step;
    std::memcpy(p + field(msg, "x")->offset, &points[i].x(), 4);
    std::memcpy(p + field(msg, "y")->offset, &points[i].y(), 4);
    std::memcpy(p + field(msg, "z")->offset, &points[i].z(), 4);
  }
  expectPoints(toPointCloud(msg), points);
}

// An offset near 2^32 wrapped `offset + 4` around the check and the reader ran 4 GiB past the buffer.
TEST(PointCloudReader, RefusesOffsetsThatWouldWrapAround) {
  for (const char* axis : {"x", "y", "z"}) {
    for (std::uint32_t offset = 0xFFFFFFFCu; offset != 0; ++offset) {  // ..0xFFFFFFFF, then wraps to 0
      auto msg = xyzCloud(kPoints);
      field(msg, axis)->offset = offset;
      expectRefused(msg, std::string("field '") + axis + "' at offset " + std::to_string(offset) +
                             " lies outside point_step 16");
    }
  }
  auto msg = xyzCloud(kPoints);
  field(msg, "z")->offset = 13;  // 13 + 4 > 16
  expectRefused(msg, "field 'z' at offset 13 lies outside point_step 16");
}

TEST(PointCloudReader, RefusesFieldsThatAreMissingDuplicatedOverlappingOrNotFloat32) {
  auto msg = xyzCloud(kPoints);
  field(msg, "y")->datatype = sensor_msgs::PointField::FLOAT64;
  expectRefused(msg, "field 'y' is not float32 (datatype 8)");
  msg = xyzCloud(kPoints);
  field(msg, "x")->datatype = sensor_msgs::PointField::INT32;
  expectRefused(msg, "field 'x' is not float32 (datatype 5)");

  // Two fields named x: which one is the coordinate is a guess, so none is taken.
  msg = xyzCloud(kPoints);
  sensor_msgs::PointField second_x = *field(msg, "x");
  second_x.offset = 12;
  msg.fields.push_back(second_x);
  expectRefused(msg, "2 fields named 'x'");

  msg = xyzCloud(kPoints);
  msg.fields.pop_back();
  expectRefused(msg, "no 'z' field");

  msg = xyzCloud(kPoints);
  field(msg, "y")->offset = 2;
  expectRefused(msg, "fields 'x' and 'y' overlap");
}

TEST(PointCloudReader, RefusesInconsistentSizes) {
  auto msg = xyzCloud(kPoints);
  msg.point_step = 0;
  expectRefused(msg, "point_step is 0");

  msg = xyzCloud(kPoints);
  msg.row_step = msg.point_step * msg.width - 1;
  expectRefused(msg, "row_step 47 is smaller than point_step x width = 48");

  msg = xyzCloud(kPoints);
  msg.data.resize(msg.data.size() - 1);
  expectRefused(msg, "data holds 47 bytes, fewer than row_step x height = 48");

  // width x height = 2^32 wraps to 0 in 32 bits: neither empty nor readable from 48 bytes.
  msg = xyzCloud(kPoints);
  msg.width = 1u << 16, msg.height = 1u << 16;
  msg.row_step = msg.point_step * msg.width;
  expectRefused(msg, "data holds 48 bytes, fewer than row_step x height = 68719476736");
  msg.width = msg.height = msg.row_step = 0xFFFFFFFFu;
  expectRefused(msg, "row_step 4294967295 is smaller than point_step x width = 68719476720");

  msg = xyzCloud({});
  expectRefused(msg, "empty cloud");
}

TEST(PointCloudReader, HonoursBigEndianData) {
  auto msg = xyzCloud(kPoints);
  for (std::size_t i = 0; i < msg.data.size(); i += 4) std::reverse(&msg.data[i], &msg.data[i] + 4);
  msg.is_bigendian = true;
  expectPoints(toPointCloud(msg), kPoints);
  // Read in the wrong byte order these coordinates would be 4.6e-41 and the like, or NaN / huge.
  msg.is_bigendian = false;
  const CloudConversion wrong = toPointCloud(msg);
  EXPECT_TRUE(!wrong.cloud || (*wrong.cloud)[0].x != 1.0f);
}

TEST(PointCloudReader, RefusesHugeCoordinatesAndCountsNonFinitePoints) {
  for (const float far : {3e38f, -1e20f, 1.5e6f}) {
    auto points = kPoints;
    points[1].y() = far;
    const CloudConversion c = toPointCloud(xyzCloud(points));
    EXPECT_FALSE(c.cloud);
    EXPECT_NE(c.error.find("point 1 has y = "), std::string::npos) << c.error;
    EXPECT_NE(c.error.find("bound of +-1e+06 m"), std::string::npos) << c.error;
  }
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  // A cloud of non-finite points is refused with its own size, not as an empty cloud ("0 of 0").
  const CloudConversion all_nan = toPointCloud(xyzCloud({{nan, nan, nan}, {nan, 0, 0}, {0, inf, 0}}));
  EXPECT_FALSE(all_nan.cloud);
  EXPECT_EQ(all_nan.dropped_non_finite, 3u);
  EXPECT_NE(all_nan.error.find("0 of its 3 points are finite"), std::string::npos) << all_nan.error;
  const CloudConversion two_finite =
      toPointCloud(xyzCloud({{nan, nan, nan}, {1, 2, 3}, {4, 5, 6}, {0, inf, 0}}));
  EXPECT_NE(two_finite.error.find("2 of its 4 points are finite"), std::string::npos) << two_finite.error;
  const CloudConversion some_nan = toPointCloud(xyzCloud({{nan, nan, nan}, {1, 2, 3}, {4, 5, 6}, {7, 8, 9}}));
  ASSERT_TRUE(some_nan.cloud) << some_nan.error;
  EXPECT_EQ(some_nan.cloud->size(), 3u);
  EXPECT_EQ(some_nan.dropped_non_finite, 1u);
  // The bound itself is allowed.
  expectPoints(toPointCloud(xyzCloud({{1e6f, -1e6f, 0}})), {{1e6f, -1e6f, 0}});
}

}  // namespace
}  // namespace mac_registration
