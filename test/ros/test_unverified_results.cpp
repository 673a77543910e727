// What the node does with a transform the verification does not confirm, against a running nodelet (real
// roscore, nodelet manager and tf): 3DMatch redkitchen fragments 21 and 0, which overlap by 1.4 %. The
// launch file is test/ros/unverified_results.test.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <mac_registration/Register.h>
#include <mac_registration/RegistrationResult.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <cmath>
#include <mutex>

#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {
namespace {

sensor_msgs::PointCloud2 cloudMessage(const std::string& path, const std::string& frame) {
  std_msgs::Header header;
  header.frame_id = frame;
  header.stamp = ros::Time::now();
  return toPointCloud2(*loadCloud(path), Eigen::Isometry3d::Identity(), header);
}

const std::string kFragment0 = std::string(MAC_DATA_DIR) + "/redkitchen_4_0/target_cloud_bin_0.pcd";
const std::string kFragment4 = std::string(MAC_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd";
const std::string kFragment21 = std::string(MAC_TEST_DATA_DIR) + "/redkitchen_21/cloud_bin_21.pcd";

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class UnverifiedResults : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService("/mac_registration/register", ros::Duration(60.0)));
  }
  ros::NodeHandle nh_;
};

// The topic path: a latched target, then a source that does not overlap it.
TEST_F(UnverifiedResults, ANonOverlappingPairGetsAResultWithTheReasonAndNoTf) {
  std::mutex mutex;
  mac_registration::RegistrationResultConstPtr received;
  std::atomic<int> aligned_clouds{0}, tf_messages{0};
  ros::Subscriber result_sub = nh_.subscribe<mac_registration::RegistrationResult>(
      "/mac_registration/result", 10, [&](const mac_registration::RegistrationResultConstPtr& r) {
        std::lock_guard<std::mutex> lock(mutex);
        if (r->child_frame_id == "apart_source") received = r;
      });
  ros::Subscriber aligned_sub = nh_.subscribe<sensor_msgs::PointCloud2>(
      "/mac_registration/aligned", 1, [&](const sensor_msgs::PointCloud2ConstPtr&) { ++aligned_clouds; });
  ros::Subscriber tf_sub =
      nh_.subscribe<tf2_msgs::TFMessage>("/tf", 100, [&](const tf2_msgs::TFMessageConstPtr& m) {
        for (const auto& t : m->transforms) tf_messages += t.child_frame_id == "apart_source";
      });
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  ros::Publisher target_pub = nh_.advertise<sensor_msgs::PointCloud2>("/target", 1, true);
  ros::Publisher source_pub = nh_.advertise<sensor_msgs::PointCloud2>("/source", 1, true);
  // The subscriptions must be connected before the node publishes, or a result could go by unseen.
  for (int i = 0; i < 100 && (result_sub.getNumPublishers() == 0 || aligned_sub.getNumPublishers() == 0); ++i)
    ros::Duration(0.05).sleep();
  ASSERT_GT(aligned_sub.getNumPublishers(), 0u);
  target_pub.publish(cloudMessage(kFragment0, "apart_target"));
  ros::Duration(1.0).sleep();  // the target must be there before the source
  source_pub.publish(cloudMessage(kFragment21, "apart_source"));
  for (int i = 0; i < 600; ++i) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (received) break;
    }
    ros::Duration(0.1).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(received) << "no result on /mac_registration/result";
  EXPECT_FALSE(received->success);
  EXPECT_EQ(received->status, mac_registration::RegistrationResult::UNVERIFIED) << received->message;
  EXPECT_TRUE(contains(received->message, "verification.min_confidence")) << received->message;
  EXPECT_LT(received->confidence, 0.5);
  // The estimate travels marked as such; the transform to act on is the identity.
  EXPECT_TRUE(received->has_estimate);
  EXPECT_FALSE(toIsometry(received->estimate).isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(toIsometry(received->transform).isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_FALSE(std::isnan(received->free_space_violation));  // the clouds were looked at
  EXPECT_FALSE(received->alternatives.empty());
  ros::Duration(2.0).sleep();  // anything the node would send after the result
  EXPECT_EQ(aligned_clouds.load(), 0);
  EXPECT_EQ(tf_messages.load(), 0);
  EXPECT_FALSE(buffer.canTransform("apart_target", "apart_source", ros::Time(0)));
}

// The service path: a rejected pair and a confirmed one, each with its confidence; /diagnostics counts the
// rejections.
TEST_F(UnverifiedResults, TheServiceAnswersBothAndDiagnosticsCountTheRejection) {
  mac_registration::Register srv;
  srv.request.source = cloudMessage(kFragment0, "service_source");
  srv.request.target = cloudMessage(kFragment21, "service_target");
  ASSERT_TRUE(ros::service::call("/mac_registration/register", srv));
  EXPECT_FALSE(srv.response.result.success);
  EXPECT_EQ(srv.response.result.status, mac_registration::RegistrationResult::UNVERIFIED)
      << srv.response.result.message;

  srv.request.source = cloudMessage(kFragment4, "service_source");
  srv.request.target = cloudMessage(kFragment0, "service_target");
  ASSERT_TRUE(ros::service::call("/mac_registration/register", srv));
  const auto& verified = srv.response.result;
  ASSERT_TRUE(verified.success) << verified.message;
  EXPECT_GT(verified.confidence, 0.9);
  EXPECT_TRUE(verified.has_estimate);
  EXPECT_TRUE(toIsometry(verified.estimate).isApprox(toIsometry(verified.transform), 1e-9));
  EXPECT_GT(verified.time_verification_ms, 0.0);
  // The evidence behind it: far above chance, and the surfaces lie along each other.
  EXPECT_GE(verified.chance_inliers, 0.0);
  EXPECT_GT(verified.chance_significance, 10.0);
  EXPECT_GT(verified.surface_agreement, 0.5);

  std::mutex mutex;
  std::size_t rejected = 0;
  bool seen = false;
  ros::Subscriber sub = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& d) {
        std::lock_guard<std::mutex> lock(mutex);
        for (const auto& status : d->status) {
          for (const auto& kv : status.values) {
            if (kv.key == "rejected by the verification") seen = true, rejected = std::stoul(kv.value);
          }
        }
      });
  for (int i = 0; i < 50; ++i) {  // the updater publishes at 1 Hz
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (seen && rejected >= 1) break;
    }
    ros::Duration(0.1).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(seen) << "no rejection counter on /diagnostics";
  EXPECT_GE(rejected, 1u);
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_unverified_results");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
