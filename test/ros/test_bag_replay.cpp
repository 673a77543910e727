// Replays a real lidar bag (rosbag play --clock, use_sim_time) against the node in latest-target mode: the
// first scan, published once as a latched target in frame "scan_0", is the map every scan is registered to.
// Every scan must get its own result, within the lidar criterion of a reference alignment, and on tf.
#include <gtest/gtest.h>
#include <mac_registration/RegistrationResult.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_listener.h>

#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {
namespace {

const std::string kBag = std::string(MAC_TEST_DATA_DIR) + "/luminar_5_scans.bag";
constexpr std::size_t kScans = 5;

// Point-to-point ICP alignments of scan j into scan 0 (the data's reference, not ground truth): rows "j T".
std::map<int, Eigen::Isometry3d> referenceAlignments() {
  std::ifstream in(std::string(MAC_TEST_DATA_DIR) + "/luminar_5_scans_reference.tsv");
  std::map<int, Eigen::Isometry3d> reference;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    int j;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    fields >> j;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) fields >> T.matrix()(r, c);
    }
    if (fields) reference[j] = T;
  }
  return reference;
}

TEST(BagReplay, EveryScanIsRegisteredToTheFirst) {
  ros::NodeHandle nh;
  rosbag::Bag bag(kBag);
  rosbag::View view(bag, rosbag::TopicQuery("/luminar_pointcloud"));
  ASSERT_EQ(view.size(), kScans);
  std::vector<ros::Time> stamps;
  sensor_msgs::PointCloud2 first;
  for (const auto& m : view) {
    auto cloud = m.instantiate<sensor_msgs::PointCloud2>();
    ASSERT_TRUE(cloud);
    if (stamps.empty()) first = *cloud;
    stamps.push_back(cloud->header.stamp);
  }

  std::mutex mutex;
  std::map<ros::Time, mac_registration::RegistrationResult> results;
  ros::Subscriber sub = nh.subscribe<mac_registration::RegistrationResult>(
      "/mac_registration/result", 10, [&](const mac_registration::RegistrationResultConstPtr& r) {
        std::lock_guard<std::mutex> lock(mutex);
        results[r->header.stamp] = *r;
      });
  first.header.frame_id = "scan_0";
  ros::Publisher target = nh.advertise<sensor_msgs::PointCloud2>("/bag_target", 1, true);
  target.publish(first);
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);

  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(240.0);
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (results.size() >= kScans) break;
    }
    ASSERT_LT(ros::WallTime::now(), deadline) << "only " << results.size() << " of " << kScans << " results";
    ros::WallDuration(0.1).sleep();
  }

  const auto reference = referenceAlignments();
  ASSERT_EQ(reference.size(), kScans - 1);
  std::lock_guard<std::mutex> lock(mutex);
  for (std::size_t j = 0; j < kScans; ++j) {
    ASSERT_TRUE(results.count(stamps[j])) << "scan " << j << " got no result of its own";
    const auto& r = results[stamps[j]];
    ASSERT_TRUE(r.success) << "scan " << j << ": " << r.status << ": " << r.message;
    EXPECT_EQ(r.header.frame_id, "scan_0");
    EXPECT_EQ(r.child_frame_id, "luminar_lidar");
    const Eigen::Isometry3d T = toIsometry(r.transform);
    const Eigen::Isometry3d expected = j == 0 ? Eigen::Isometry3d::Identity() : reference.at(int(j));
    // The lidar benchmark criterion (RE <= 5 deg, TE <= 0.6 m) against the ICP reference.
    EXPECT_LE(rotationErrorDeg(T, expected), 5.0) << "scan " << j;
    EXPECT_LE(translationError(T, expected), 0.6) << "scan " << j;
    std::cout << "scan " << j << ": t = [" << T.translation().transpose() << "] m, " << r.inliers
              << " inliers of " << r.correspondences << ", front end " << r.time_front_end_ms << " ms, total "
              << r.time_total_ms << " ms\n";
  }
  // The last result is on tf, at its scan's (simulated) time.
  const auto tf = buffer.lookupTransform("scan_0", "luminar_lidar", stamps.back(), ros::Duration(5.0));
  EXPECT_NEAR(tf.transform.translation.y, results[stamps.back()].transform.translation.y, 1e-6);
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bag_replay");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
