// The relocalization query window: scans joined by their odometry into the newest scan's frame, kept as
// keyframes by travel and turn, bounded by length and age.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "mac_registration/features/query_window.hpp"

namespace mac_registration {
namespace {

// A corridor of posts in the odom frame, 1 m apart, seen from a sensor at `T_odom_scan` (its frame).
PointCloud scanOfPosts(const Eigen::Isometry3d& T_odom_scan) {
  PointCloud scan;
  const Eigen::Isometry3d T_scan_odom = T_odom_scan.inverse();
  for (int post = -40; post <= 40; ++post) {
    for (int side = -1; side <= 1; side += 2) {
      for (int level = 0; level < 5; ++level) {
        const Eigen::Vector3d p = T_scan_odom * Eigen::Vector3d(post, 3.0 * side, 0.4 * level);
        scan.push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
      }
    }
  }
  scan.push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f));
  return scan;
}

Eigen::Isometry3d poseAt(double x, double yaw = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Eigen::Vector3d(x, 0.5, 0.2));
  T.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return T;
}

QueryWindowParams params(double length, double max_age) {
  QueryWindowParams p;
  p.length = length;
  p.max_age = max_age;
  p.voxel_size = 0.1;
  return p;
}

TEST(QueryWindow, JoinsTheScansInTheNewestFrame) {
  QueryWindow window(params(16.0, 60.0));
  for (int i = 0; i < 60; ++i) {
    const Eigen::Isometry3d pose = poseAt(0.3 * i, 0.01 * i);
    window.add(scanOfPosts(pose), pose, 0.1 * i);
  }
  // A keyframe once the sensor has moved a metre (length / 16): at 0, 1.2, ... 16.8 m; the first is more
  // than 16 m behind the newest.
  EXPECT_EQ(window.keyframes(), 14u);
  EXPECT_NEAR(window.travel(), 15.6, 1e-6);
  EXPECT_TRUE(window.newestPose().isApprox(poseAt(16.8, 0.56)));
  const PointCloud::Ptr joined = window.assemble();
  ASSERT_FALSE(joined->empty());
  // Every joined point, taken back to odom, is a post's point: the scans agree where they overlap.
  for (const pcl::PointXYZ& p : *joined) {
    const Eigen::Vector3d q = window.newestPose() * p.getVector3fMap().cast<double>();
    ASSERT_TRUE(std::isfinite(q.x()));
    EXPECT_NEAR(q.x(), std::round(q.x()), 1e-3);
    EXPECT_NEAR(std::abs(q.y()), 3.0, 1e-3);
  }
}

TEST(QueryWindow, StandingStillKeepsOneKeyframe) {
  QueryWindow window(params(16.0, 60.0));
  for (int i = 0; i < 100; ++i) window.add(scanOfPosts(poseAt(2.0)), poseAt(2.0), 0.1 * i);
  EXPECT_EQ(window.keyframes(), 1u);
  // A turn on the spot is a new view.
  window.add(scanOfPosts(poseAt(2.0, 0.3)), poseAt(2.0, 0.3), 10.1);
  EXPECT_EQ(window.keyframes(), 2u);
}

TEST(QueryWindow, KeyframesOlderThanTheAgeLeave) {
  QueryWindow window(params(32.0, 60.0));
  for (int i = 0; i < 20; ++i) window.add(scanOfPosts(poseAt(2.5 * i)), poseAt(2.5 * i), 10.0 * i);
  EXPECT_EQ(window.keyframes(), 7u);  // stamps 130 ... 190 s, 15 m of travel
  // Scans that are not kept still age the window, down to its newest keyframe.
  for (int i = 0; i < 10; ++i) window.add(scanOfPosts(poseAt(47.5)), poseAt(47.5), 200.0 + 100.0 * i);
  EXPECT_EQ(window.keyframes(), 1u);
}

TEST(QueryWindow, AnEarlierStampStartsAgain) {
  QueryWindow window(params(16.0, 60.0));
  for (int i = 0; i < 5; ++i) window.add(scanOfPosts(poseAt(2.0 * i)), poseAt(2.0 * i), 100.0 + i);
  EXPECT_EQ(window.keyframes(), 5u);
  window.add(scanOfPosts(poseAt(9.0)), poseAt(9.0), 1.0);
  EXPECT_EQ(window.keyframes(), 1u);
  EXPECT_DOUBLE_EQ(window.newestStamp(), 1.0);
}

TEST(QueryWindow, ZeroLengthIsTheLatestScan) {
  QueryWindow window(params(0.0, 60.0));
  for (int i = 0; i < 5; ++i) window.add(scanOfPosts(poseAt(0.01 * i)), poseAt(0.01 * i), i);
  EXPECT_EQ(window.keyframes(), 1u);
  EXPECT_TRUE(window.newestPose().isApprox(poseAt(0.04)));
}

TEST(QueryWindow, RefusesInvalidParameters) {
  EXPECT_THROW(QueryWindow(params(-1.0, 60.0)), std::invalid_argument);
  EXPECT_THROW(QueryWindow(params(16.0, -1.0)), std::invalid_argument);
  QueryWindowParams p = params(16.0, 60.0);
  p.voxel_size = 0.0;
  EXPECT_THROW(QueryWindow{p}, std::invalid_argument);
  EXPECT_TRUE(QueryWindow(params(16.0, 60.0)).assemble()->empty());
}

}  // namespace
}  // namespace mac_registration
