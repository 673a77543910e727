// The relocalization node as a robot uses it: a map file loaded at start, ~relocalize called with a scan or
// with nothing (the latest scan on `source`), the verified pose on ~pose and on tf as map -> odom, the map
// on ~map_cloud; a scan of no mapped place is not localized.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <mac_registration/Relocalize.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>
#include <map>

#include <mutex>

#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {
namespace {

const std::string kService = "/mac_relocalization/relocalize";

std::string dataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }

sensor_msgs::PointCloud2 cloudMsg(const std::string& file, const std::string& frame) {
  std_msgs::Header header;
  header.frame_id = frame;
  header.stamp = ros::Time::now();
  return toPointCloud2(*loadCloud(dataPath(file)), Eigen::Isometry3d::Identity(), header);
}

Eigen::Isometry3d reference() {
  return readTransformFile(dataPath("lidar/lidar_T_target_source_reference.txt"));
}

Eigen::Isometry3d toEigen(const geometry_msgs::Pose& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() << pose.position.x, pose.position.y, pose.position.z;
  T.linear() =
      Eigen::Quaterniond(pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z)
          .toRotationMatrix();
  return T;
}

class RelocalizationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService(kService, ros::Duration(60.0)));
    ASSERT_TRUE(buffer_.canTransform("odom", "lidar", ros::Time(0), ros::Duration(10.0)));
  }

  // Calls until the map is described (the node answers "no map" while it loads).
  RelocalizationAnswer call(const sensor_msgs::PointCloud2& cloud, Relocalize::Request request = {}) {
    Relocalize srv;
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(60.0);
    do {
      srv.request = request;
      srv.request.cloud = cloud;
      srv.request.cloud.header.stamp = ros::Time::now();
      EXPECT_TRUE(ros::service::call(kService, srv));
      if (srv.response.result.outcome != "no map") break;
      ros::WallDuration(0.2).sleep();
    } while (ros::WallTime::now() < give_up);
    return srv.response.result;
  }

  ros::NodeHandle nh_;
  tf2_ros::Buffer buffer_;
  tf2_ros::TransformListener listener_{buffer_};
};

// The latest message on a topic, received on the test's spinner thread.
template <typename Message>
class Latest {
 public:
  Latest(ros::NodeHandle& nh, const std::string& topic)
      : sub_(nh.subscribe<Message>(topic, 1, [this](const boost::shared_ptr<const Message>& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          message_ = m;
        })) {}
  // Waits up to `seconds` until a publisher is connected: a message sent before that is not received.
  bool connected(double seconds) {
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(seconds);
    while (sub_.getNumPublishers() == 0 && ros::WallTime::now() < give_up) ros::WallDuration(0.05).sleep();
    return sub_.getNumPublishers() > 0;
  }
  // Waits up to `seconds` for a message.
  boost::shared_ptr<const Message> wait(double seconds) {
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::WallTime::now() < give_up) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (message_) return message_;
      }
      ros::WallDuration(0.05).sleep();
    }
    return nullptr;
  }

 private:
  std::mutex mutex_;
  boost::shared_ptr<const Message> message_;
  ros::Subscriber sub_;
};

TEST_F(RelocalizationTest, LocalizesAScanAndPublishesThePoseAndMapToOdom) {
  Latest<geometry_msgs::PoseWithCovarianceStamped> pose(nh_, "/mac_relocalization/pose");
  ASSERT_TRUE(pose.connected(10.0));  // ~pose is not latched
  const RelocalizationAnswer r = call(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"));
  ASSERT_TRUE(r.success) << r.outcome << ": " << r.message;
  EXPECT_EQ(r.outcome, "localized");
  EXPECT_TRUE(r.message.empty()) << r.message;  // map -> odom was published too
  const Eigen::Isometry3d T = toEigen(r.pose.pose.pose);
  EXPECT_LT(rotationErrorDeg(T, reference()), 1.0);
  EXPECT_LT(translationError(T, reference()), 0.2);
  EXPECT_EQ(r.pose.header.frame_id, "map");
  EXPECT_GT(r.pose.pose.covariance[0], 0.0);
  EXPECT_LT(r.pose.pose.covariance[0], 0.01);  // [m^2] x of a pose the map pins down
  ASSERT_FALSE(r.candidates.empty());
  for (std::size_t k = 1; k < r.candidates.size(); ++k)
    EXPECT_LE(r.candidates[k].score, r.candidates[k - 1].score);
  bool verified = false;
  for (const auto& c : r.candidates) verified = verified || c.verified;
  EXPECT_TRUE(verified);

  // REP-105: map -> odom -> lidar at the current time is the pose found.
  ros::WallDuration(0.5).sleep();
  const Eigen::Isometry3d map_lidar =
      tf2::transformToEigen(buffer_.lookupTransform("map", "lidar", ros::Time::now(), ros::Duration(2.0)));
  EXPECT_TRUE(map_lidar.isApprox(T, 1e-4)) << map_lidar.matrix() << "\n" << T.matrix();
  const auto published = pose.wait(5.0);
  ASSERT_TRUE(published);
  EXPECT_TRUE(toEigen(published->pose.pose).isApprox(T, 1e-9));
}

TEST_F(RelocalizationTest, AnEmptyRequestLocalizesTheLatestScanOnSource) {
  const RelocalizationAnswer before = call(sensor_msgs::PointCloud2());
  if (!before.success) {
    EXPECT_NE(before.message.find("source"), std::string::npos) << before.message;
  }
  ros::Publisher pub = nh_.advertise<sensor_msgs::PointCloud2>("/source", 1, /*latch=*/true);
  pub.publish(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"));
  RelocalizationAnswer r;
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(10.0);
  do {
    r = call(sensor_msgs::PointCloud2());
    if (r.success) break;
    ros::WallDuration(0.2).sleep();
  } while (ros::WallTime::now() < give_up);
  ASSERT_TRUE(r.success) << r.outcome << ": " << r.message;
  EXPECT_LT(translationError(toEigen(r.pose.pose.pose), reference()), 0.2);
}

// The source scan split in two halves seen from two odometry poses 3 m apart, as a robot driving by
// would see them: the window joins them in the newest scan's frame.
TEST_F(RelocalizationTest, AnEmptyRequestLocalizesTheWindowOfKeyframes) {
  const PointCloud::Ptr scan = loadCloud(dataPath("lidar/lidar_source_251371071.pcd"));
  Eigen::Isometry3d odom_lidar = Eigen::Isometry3d::Identity();  // as the launch file's static transform
  odom_lidar.translation() << 1.0, 2.0, 0.0;
  odom_lidar.rotate(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  const Eigen::Isometry3d behind(
      Eigen::Translation3d(-3.0, 0.0, 0.0));  // the first view, in the last's frame
  PointCloud back, front;
  for (const auto& p : *scan) {
    if (!std::isfinite(p.x)) continue;
    if (p.x < 0.0f) {
      back.push_back(p);
    } else {
      front.push_back(p);
    }
  }
  tf2_ros::TransformBroadcaster odometry;
  ros::Publisher pub = nh_.advertise<sensor_msgs::PointCloud2>("/source", 2);
  ros::WallDuration(0.5).sleep();  // the node connects
  const std::pair<const PointCloud*, Eigen::Isometry3d> views[] = {{&back, behind},
                                                                   {&front, Eigen::Isometry3d::Identity()}};
  for (const auto& [points, view] : views) {
    std_msgs::Header header;
    header.frame_id = "lidar_moving";
    header.stamp = ros::Time::now();
    geometry_msgs::TransformStamped odom = tf2::eigenToTransform(odom_lidar * view);
    odom.header.frame_id = "odom";
    odom.header.stamp = header.stamp;
    odom.child_frame_id = "lidar_moving";
    odometry.sendTransform(odom);
    ros::WallDuration(0.3).sleep();
    pub.publish(toPointCloud2(*points, view.inverse(), header));
    ros::WallDuration(0.3).sleep();
  }
  const RelocalizationAnswer r = call(sensor_msgs::PointCloud2());
  ASSERT_TRUE(r.success) << r.outcome << ": " << r.message;
  EXPECT_NE(r.query.find("window of 2 keyframes"), std::string::npos) << r.query;
  EXPECT_EQ(r.trigger, "service");
  EXPECT_LT(rotationErrorDeg(toEigen(r.pose.pose.pose), reference()), 1.0);
  EXPECT_LT(translationError(toEigen(r.pose.pose.pose), reference()), 0.2);
}

TEST_F(RelocalizationTest, APriorKeepsTheSearchAroundIt) {
  Relocalize::Request near;
  near.use_prior = true;
  near.prior.x = reference().translation().x() + 5.0;
  near.prior.y = reference().translation().y() - 5.0;
  near.prior_radius = 30.0;
  const RelocalizationAnswer r = call(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"), near);
  ASSERT_TRUE(r.success) << r.outcome << ": " << r.message;
  EXPECT_LT(translationError(toEigen(r.pose.pose.pose), reference()), 0.2);
  Relocalize::Request far = near;
  far.prior.x += 500.0;
  const RelocalizationAnswer outside = call(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"), far);
  EXPECT_FALSE(outside.success);
  EXPECT_EQ(outside.outcome, "not localized");
  EXPECT_NE(outside.message.find("search area"), std::string::npos) << outside.message;
}

TEST_F(RelocalizationTest, TheMapAndTheAnswersAreOnDiagnostics) {
  call(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"));
  std::mutex mutex;
  std::map<std::string, std::string> values;
  ros::Subscriber sub = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& array) {
        for (const auto& status : array->status) {
          if (status.name.find("mac_relocalization: relocalization") == std::string::npos) continue;
          std::lock_guard<std::mutex> lock(mutex);
          for (const auto& kv : status.values) values[kv.key] = kv.value;
        }
      });
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(5.0);
  while (ros::WallTime::now() < give_up) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!values.empty()) break;
    }
    ros::WallDuration(0.1).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_FALSE(values.empty());
  EXPECT_EQ(values["map"].rfind("ready", 0), 0u) << values["map"];
  EXPECT_GT(std::stoi(values["map keypoints"]), 1000);
  EXPECT_GT(std::stod(values["map description [s]"]), 0.0);
  EXPECT_GE(std::stoi(values["localized"]), 1);
}

TEST_F(RelocalizationTest, AScanOfNoMappedPlaceIsNotLocalized) {
  const RelocalizationAnswer r = call(cloudMsg("redkitchen_4_0/target_cloud_bin_0.pcd", "lidar"));
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.outcome, "not localized");
  EXPECT_FALSE(r.message.empty());
}

// A second node takes its map from the `map` topic and relocalizes on its own at start-up; its verified
// pose, sent on initialpose, is the first node's prior.
TEST_F(RelocalizationTest, AMapTopicAndRelocalizationOnStart) {
  Latest<RelocalizationAnswer> started(nh_, "/mac_relocalization_start/result");
  Latest<geometry_msgs::PoseWithCovarianceStamped> initialpose(nh_, "/initialpose");
  Latest<RelocalizationAnswer> prior(nh_, "/mac_relocalization/result");
  ros::Publisher map = nh_.advertise<sensor_msgs::PointCloud2>("/map", 1, /*latch=*/true);
  map.publish(cloudMsg("lidar/lidar_target_251370668.pcd", "map"));
  ros::Publisher scans = nh_.advertise<sensor_msgs::PointCloud2>("/source_start", 1, /*latch=*/true);
  scans.publish(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"));
  const auto answer = started.wait(90.0);
  ASSERT_TRUE(answer);
  EXPECT_TRUE(answer->success) << answer->outcome << ": " << answer->message;
  EXPECT_EQ(answer->trigger, "start");
  EXPECT_LT(translationError(toEigen(answer->pose.pose.pose), reference()), 0.2);
  const auto sent = initialpose.wait(10.0);
  ASSERT_TRUE(sent);
  EXPECT_TRUE(toEigen(sent->pose.pose).isApprox(toEigen(answer->pose.pose.pose), 1e-9));
  // The first node relocalizes its own query around that prior.
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(30.0);
  boost::shared_ptr<const RelocalizationAnswer> around;
  while (ros::WallTime::now() < give_up) {
    around = prior.wait(1.0);
    if (around && around->trigger == "initialpose") break;
  }
  ASSERT_TRUE(around);
  EXPECT_EQ(around->trigger, "initialpose");
  EXPECT_NE(around->outcome, "no map");
}

TEST_F(RelocalizationTest, TheMapIsLatchedOnMapCloud) {
  call(cloudMsg("lidar/lidar_source_251371071.pcd", "lidar"));  // the map is described by now
  Latest<sensor_msgs::PointCloud2> latched(nh_, "/mac_relocalization/map_cloud");
  const auto map = latched.wait(10.0);
  ASSERT_TRUE(map);
  EXPECT_EQ(map->header.frame_id, "map");
  EXPECT_GT(map->width * map->height, 1000u);
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_relocalization");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
