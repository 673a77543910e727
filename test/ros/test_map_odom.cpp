// tf_mode map_odom (REP-105): the node publishes map -> odom so that map -> odom -> scan equals the
// registration, using the odom -> scan transform already on tf; without it, no tf and a warning.
#include <gtest/gtest.h>
#include <mac_registration/RegisterCorrespondences.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/transform_listener.h>

#include "mac_registration/core/text_io.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {
namespace {

mac_registration::RegisterCorrespondences request(const std::string& source_frame) {
  std_msgs::Header header;
  header.frame_id = "map";
  header.stamp = ros::Time::now();
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = toCorrespondencesMsg(
      readCorrespondencesFile(std::string(MAC_TEST_DATA_DIR) + "/redkitchen_24_59/correspondences.txt"),
      header, source_frame);
  return srv;
}

Eigen::Isometry3d toEigen(const geometry_msgs::Transform& t) { return toIsometry(t); }

TEST(MapOdom, PublishesMapToOdomFromTheExistingOdometry) {
  ASSERT_TRUE(
      ros::service::waitForService("/mac_registration/register_correspondences", ros::Duration(60.0)));
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  // The launch file's static odom -> scan transform must be known before the registration looks it up.
  ASSERT_TRUE(buffer.canTransform("odom", "scan", ros::Time(0), ros::Duration(10.0)));
  auto srv = request("scan");
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  const auto& result = srv.response.result;
  ASSERT_TRUE(result.success) << result.message;
  for (const auto& w : result.warnings) EXPECT_EQ(w.find("tf not published"), std::string::npos) << w;
  const auto map_scan = buffer.lookupTransform("map", "scan", ros::Time(0), ros::Duration(5.0));
  // map -> odom -> scan reproduces the registration.
  EXPECT_TRUE(tf2::transformToEigen(map_scan).isApprox(toEigen(result.transform), 1e-6));
  const auto map_odom = buffer.lookupTransform("map", "odom", ros::Time(0), ros::Duration(5.0));
  EXPECT_FALSE(tf2::transformToEigen(map_odom).isApprox(toEigen(result.transform), 1e-3));
}

TEST(MapOdom, MissingOdometryMeansNoTfAndAWarning) {
  ASSERT_TRUE(
      ros::service::waitForService("/mac_registration/register_correspondences", ros::Duration(60.0)));
  auto srv = request("frame_without_odometry");
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  const auto& result = srv.response.result;
  ASSERT_TRUE(result.success) << result.message;
  bool warned = false;
  for (const auto& w : result.warnings) warned |= w.find("tf not published") != std::string::npos;
  EXPECT_TRUE(warned);
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_map_odom");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
