// A latched target against a running nodelet (real roscore and nodelet manager; scans from a real lidar
// bag): the target's keypoints and descriptors are computed once per target message and per change of the
// feature parameters, not once per scan. /diagnostics counts the descriptions ("target descriptions").
// The launch file is test/ros/latched_target.test.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <gtest/gtest.h>
#include <mac_registration/RegistrationResult.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>

#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace mac_registration {
namespace {

const std::string kBag = std::string(MAC_TEST_DATA_DIR) + "/luminar_5_scans.bag";

std::vector<sensor_msgs::PointCloud2> bagScans() {
  rosbag::Bag bag(kBag);
  std::vector<sensor_msgs::PointCloud2> scans;
  for (const auto& m : rosbag::View(bag, rosbag::TopicQuery("/luminar_pointcloud"))) {
    if (auto cloud = m.instantiate<sensor_msgs::PointCloud2>()) scans.push_back(*cloud);
  }
  return scans;
}

class LatchedTargetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scans_ = bagScans();
    ASSERT_EQ(scans_.size(), 5u);
    results_sub_ = nh_.subscribe<mac_registration::RegistrationResult>(
        "/mac_registration/result", 10, [this](const mac_registration::RegistrationResultConstPtr& r) {
          std::lock_guard<std::mutex> lock(mutex_);
          results_[r->header.stamp] = *r;
        });
    diagnostics_sub_ = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 10, [this](const diagnostic_msgs::DiagnosticArrayConstPtr& d) {
          for (const auto& status : d->status) {
            if (status.name.find("registration") == std::string::npos) continue;
            std::lock_guard<std::mutex> lock(mutex_);
            diagnostics_.clear();
            for (const auto& kv : status.values) diagnostics_[kv.key] = kv.value;
          }
        });
    source_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("/latched_test/source", 1);
    target_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("/latched_test/target", 1, true);
    for (int i = 0; i < 200 && source_pub_.getNumSubscribers() == 0; ++i) ros::Duration(0.05).sleep();
    ASSERT_GT(source_pub_.getNumSubscribers(), 0u) << "the nodelet does not subscribe to the source";
  }

  void latchTarget(int scan) {
    sensor_msgs::PointCloud2 target = scans_[scan];
    target.header.frame_id = "latched_map";
    target.header.stamp = ros::Time::now();
    target_pub_.publish(target);
    ros::Duration(0.5).sleep();  // the node keeps the latest target before the next source arrives
  }

  // Publishes one scan as the source, stamped now, and waits for its own result.
  mac_registration::RegistrationResult registerScan(int scan) {
    sensor_msgs::PointCloud2 source = scans_[scan];
    source.header.stamp = ros::Time::now();
    source_pub_.publish(source);
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(60.0);
    while (ros::WallTime::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        const auto found = results_.find(source.header.stamp);
        if (found != results_.end()) return found->second;
      }
      ros::WallDuration(0.02).sleep();
    }
    ADD_FAILURE() << "no result for scan " << scan;
    return {};
  }

  // A diagnostics value once the node reports `registrations` results (the updater publishes at 1 Hz).
  std::string diagnostic(const std::string& key, std::size_t registrations) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
    while (ros::WallTime::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        const auto count = diagnostics_.find("registrations");
        if (count != diagnostics_.end() && std::stoul(count->second) == registrations &&
            diagnostics_.count(key)) {
          return diagnostics_[key];
        }
      }
      ros::WallDuration(0.05).sleep();
    }
    ADD_FAILURE() << "no /diagnostics with " << registrations << " registrations and a '" << key << "'";
    return "";
  }

  std::size_t targetDescriptions(std::size_t registrations) {
    const std::string value = diagnostic("target descriptions", registrations);
    return value.empty() ? 0 : std::stoul(value);
  }

  static void setVoxelSize(double voxel_size) {
    dynamic_reconfigure::Reconfigure srv;
    dynamic_reconfigure::DoubleParameter voxel;
    voxel.name = "features_voxel_size";
    voxel.value = voxel_size;
    srv.request.config.doubles.push_back(voxel);
    ASSERT_TRUE(ros::service::call("/mac_registration/set_parameters", srv));
  }

  ros::NodeHandle nh_;
  std::vector<sensor_msgs::PointCloud2> scans_;
  ros::Subscriber results_sub_, diagnostics_sub_;
  ros::Publisher source_pub_, target_pub_;
  std::mutex mutex_;
  std::map<ros::Time, mac_registration::RegistrationResult> results_;
  std::map<std::string, std::string> diagnostics_;
};

TEST_F(LatchedTargetTest, TheTargetIsDescribedOncePerMessageAndFeatureParameters) {
  latchTarget(0);
  std::size_t registrations = 0;
  std::uint32_t target_keypoints = 0;
  for (int scan : {1, 2, 3, 4}) {
    const auto result = registerScan(scan);
    ++registrations;
    EXPECT_TRUE(result.success) << "scan " << scan << ": " << result.message;
    EXPECT_EQ(result.header.frame_id, "latched_map");
    target_keypoints = result.target_keypoints;
  }
  EXPECT_EQ(targetDescriptions(registrations), 1u) << "four scans against one latched target";
  EXPECT_EQ(diagnostic("inputs received", registrations), "4");
  EXPECT_EQ(diagnostic("inputs dropped (worker busy)", registrations), "0");  // one scan at a time

  // A new message on `target` is a new target, even with the same points.
  latchTarget(0);
  registerScan(1);
  EXPECT_EQ(targetDescriptions(++registrations), 2u);
  registerScan(2);
  EXPECT_EQ(targetDescriptions(++registrations), 2u);

  // Other descriptors: the target is described again, once.
  setVoxelSize(1.2);
  const auto coarser = registerScan(3);
  EXPECT_EQ(targetDescriptions(++registrations), 3u);
  EXPECT_LT(coarser.target_keypoints, target_keypoints) << "coarser voxels, fewer target keypoints";
  registerScan(4);
  EXPECT_EQ(targetDescriptions(++registrations), 3u);
  EXPECT_EQ(diagnostic("inputs received", registrations), "8");
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_latched_target");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
