// tf_mode map_odom (REP-105): the node publishes map -> odom so that map -> odom -> scan equals the
// registration, using the odom -> scan transform already on tf, and keeps re-sending the latest correction
// so that a consumer's lookup at the current time works between registrations and after the last one.
// Without the odometry the registration is a failure and the previous correction stays.
#include <gtest/gtest.h>
#include <mac_registration/RegisterCorrespondences.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/transform_listener.h>

#include "mac_registration/core/text_io.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {
namespace {

const std::string kService = "/mac_registration/register_correspondences";

// The real redkitchen 24 -> 59 matches, their targets moved by `shift` so that each shift is a different
// registration result.
mac_registration::RegisterCorrespondences request(const std::string& source_frame,
                                                  const Eigen::Vector3d& shift = Eigen::Vector3d::Zero(),
                                                  ros::Time stamp = ros::Time::now()) {
  CorrespondenceSet set =
      readCorrespondencesFile(std::string(MAC_TEST_DATA_DIR) + "/redkitchen_24_59/correspondences.txt");
  set.target_points.colwise() += shift;
  std_msgs::Header header;
  header.frame_id = "map";
  header.stamp = stamp;
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = toCorrespondencesMsg(set, header, source_frame);
  return srv;
}

Eigen::Isometry3d toEigen(const geometry_msgs::Transform& t) { return toIsometry(t); }

class MapOdomTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService(kService, ros::Duration(60.0)));
    // The launch file's static odom -> scan transform must be known before a registration looks it up:
    // here, and in the node, whose listener receives it on its own thread (a loaded machine can answer a
    // first call before it has; the node then says "missing odometry", rightly).
    ASSERT_TRUE(buffer_.canTransform("odom", "scan", ros::Time(0), ros::Duration(10.0)));
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(10.0);
    while (registerSet(request("scan")).status == mac_registration::RegistrationResult::MISSING_ODOMETRY &&
           ros::WallTime::now() < give_up)
      ros::WallDuration(0.1).sleep();
  }

  mac_registration::RegistrationResult registerSet(mac_registration::RegisterCorrespondences srv) {
    EXPECT_TRUE(ros::service::call(kService, srv));
    return srv.response.result;
  }

  // What a REP-105 consumer does: map -> scan at the current time, waiting briefly for tf to catch up.
  // Called at least transform_tolerance (0.1 s) after a registration: until then "now" lies between the
  // previous correction's post-dated stamps and the new one's, and tf interpolates between the two.
  Eigen::Isometry3d mapToScanNow() {
    const auto tf = buffer_.lookupTransform("map", "scan", ros::Time::now(), ros::Duration(1.0));
    return tf2::transformToEigen(tf);
  }

  tf2_ros::Buffer buffer_;
  tf2_ros::TransformListener listener_{buffer_};
};

TEST_F(MapOdomTest, PublishesMapToOdomFromTheExistingOdometry) {
  const auto result = registerSet(request("scan"));
  ASSERT_TRUE(result.success) << result.message;
  for (const auto& w : result.warnings) EXPECT_EQ(w.find("tf not published"), std::string::npos) << w;
  ros::WallDuration(0.5).sleep();
  // map -> odom -> scan reproduces the registration; map -> odom itself is not the registration.
  EXPECT_TRUE(mapToScanNow().isApprox(toEigen(result.transform), 1e-6));
  const auto map_odom = buffer_.lookupTransform("map", "odom", ros::Time(0), ros::Duration(5.0));
  EXPECT_FALSE(tf2::transformToEigen(map_odom).isApprox(toEigen(result.transform), 1e-3));
}

// Seconds after a registration, and after the next one, "now" still resolves, to the latest correction.
TEST_F(MapOdomTest, LookupsAtTheCurrentTimeWorkBetweenAndAfterRegistrations) {
  const auto first = registerSet(request("scan", Eigen::Vector3d(0.5, 0.0, 0.0)));
  ASSERT_TRUE(first.success) << first.message;
  ros::WallDuration(2.0).sleep();  // far longer than the post-dating (transform_tolerance)
  EXPECT_TRUE(mapToScanNow().isApprox(toEigen(first.transform), 1e-6));

  const auto second = registerSet(request("scan", Eigen::Vector3d(0.0, -0.7, 0.2)));
  ASSERT_TRUE(second.success) << second.message;
  ASSERT_FALSE(toEigen(second.transform).isApprox(toEigen(first.transform), 1e-3));
  ros::WallDuration(0.5).sleep();
  EXPECT_TRUE(mapToScanNow().isApprox(toEigen(second.transform), 1e-6));
  ros::WallDuration(2.0).sleep();
  EXPECT_TRUE(mapToScanNow().isApprox(toEigen(second.transform), 1e-6));
}

TEST_F(MapOdomTest, MissingOdometryIsAFailureAndKeepsThePreviousCorrection) {
  const auto good = registerSet(request("scan", Eigen::Vector3d(0.3, 0.3, 0.0)));
  ASSERT_TRUE(good.success) << good.message;

  const auto result = registerSet(request("frame_without_odometry"));
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.status, mac_registration::RegistrationResult::MISSING_ODOMETRY);
  EXPECT_NE(result.message.find("odom <- frame_without_odometry"), std::string::npos) << result.message;
  EXPECT_TRUE(toEigen(result.transform).isApprox(Eigen::Isometry3d::Identity()));

  ros::WallDuration(1.0).sleep();
  EXPECT_TRUE(mapToScanNow().isApprox(toEigen(good.transform), 1e-6));
}

// A zero stamp would put map -> odom at t = 0 (TF_OLD_DATA in every listener): the node uses the arrival
// time and the latest odometry, and says so.
TEST_F(MapOdomTest, AZeroStampIsReplacedByTheArrivalTime) {
  const ros::Time before = ros::Time::now();
  const auto result = registerSet(request("scan", Eigen::Vector3d(-0.4, 0.0, 0.1), ros::Time(0)));
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_GE(result.header.stamp, before);
  bool said = false;
  for (const auto& w : result.warnings) said |= w.find("header.stamp is zero") != std::string::npos;
  EXPECT_TRUE(said);
  ros::WallDuration(0.5).sleep();
  EXPECT_TRUE(mapToScanNow().isApprox(toEigen(result.transform), 1e-6));
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
