// Interface test against a running nodelet (real roscore, nodelet manager and tf): services, topics, tf and
// bad input. The launch file is test/ros/registration_server.test.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <gtest/gtest.h>
#include <mac_registration/Register.h>
#include <mac_registration/RegisterCandidates.h>
#include <mac_registration/RegisterCorrespondences.h>
#include <mac_registration/RegistrationResult.h>
#include <ros/ros.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <limits>
#include <memory>

#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/ros/conversions.hpp"
#include "xyz_cloud.hpp"

namespace mac_registration {
namespace {

const std::string kData = MAC_TEST_DATA_DIR;  // test-only data
const std::string kDemoData = MAC_DATA_DIR;   // the demo's scans

Eigen::Isometry3d toEigen(const geometry_msgs::Transform& t) { return toIsometry(t); }

mac_registration::Correspondences redkitchenCorrespondences(const std::string& target_frame,
                                                            const std::string& source_frame) {
  std_msgs::Header header;
  header.frame_id = target_frame;
  header.stamp = ros::Time::now();
  return toCorrespondencesMsg(readCorrespondencesFile(kData + "/redkitchen_24_59/correspondences.txt"),
                              header, source_frame);
}

using mac_registration::test::xyzCloud;

// A real 3DMatch pair (redkitchen fragments 4 -> 0, 37.5 % overlap, 3 cm voxels) as PointCloud2 messages.
sensor_msgs::PointCloud2 redkitchenCloud(const std::string& file, const std::string& frame) {
  std_msgs::Header header;
  header.frame_id = frame;
  header.stamp = ros::Time::now();
  return toPointCloud2(*loadCloud(kDemoData + "/redkitchen_4_0/" + file), Eigen::Isometry3d::Identity(),
                       header);
}

void expectWithinBenchmarkCriterion(const mac_registration::RegistrationResult& result) {
  ASSERT_TRUE(result.success) << statusName(result.status) << ": " << result.message;
  const Eigen::Isometry3d truth = readTransformFile(kDemoData + "/redkitchen_4_0/T_target_source_gt.txt");
  EXPECT_LE(rotationErrorDeg(toEigen(result.transform), truth), 15.0);
  EXPECT_LE(translationError(toEigen(result.transform), truth), 0.30);
}

class RegistrationServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService("/mac_registration/register", ros::Duration(60.0)));
    ASSERT_TRUE(
        ros::service::waitForService("/mac_registration/register_correspondences", ros::Duration(10.0)));
  }

  mac_registration::RegistrationResult callRegister(const sensor_msgs::PointCloud2& source,
                                                    const sensor_msgs::PointCloud2& target) {
    mac_registration::Register srv;
    srv.request.source = source;
    srv.request.target = target;
    EXPECT_TRUE(ros::service::call("/mac_registration/register", srv));
    return srv.response.result;
  }

  // The transforms the node sends for `child_frame`, recorded from a /tf subscription that is connected
  // before the test goes on: a one-shot transform sent earlier would go by unseen.
  struct TfRecorder {
    ros::Subscriber subscription;
    std::shared_ptr<geometry_msgs::TransformStamped> latest =
        std::make_shared<geometry_msgs::TransformStamped>();
  };
  TfRecorder recordTf(const std::string& child_frame) {
    TfRecorder recorder;
    auto latest = recorder.latest;
    recorder.subscription = nh_.subscribe<tf2_msgs::TFMessage>(
        "/tf", 100, [latest, child_frame](const tf2_msgs::TFMessageConstPtr& m) {
          for (const auto& t : m->transforms) {
            if (t.child_frame_id == child_frame) *latest = t;
          }
        });
    waitForPublisher(recorder.subscription, "/tf");
    return recorder;
  }

  static void waitForPublisher(const ros::Subscriber& subscription, const std::string& topic) {
    for (int i = 0; i < 100 && subscription.getNumPublishers() == 0; ++i) ros::Duration(0.05).sleep();
    ASSERT_GT(subscription.getNumPublishers(), 0u) << "nobody publishes " << topic;
  }

  static bool waitFor(const geometry_msgs::TransformStamped& tf) {
    for (int i = 0; i < 100 && tf.child_frame_id.empty(); ++i) ros::Duration(0.05).sleep();
    return !tf.child_frame_id.empty();
  }

  ros::NodeHandle nh_;
};

// Real FPFH matches of 3DMatch redkitchen 24 -> 59 (3.7 % inliers) through the service.
TEST_F(RegistrationServerTest, RegisterCorrespondencesServiceMeetsTheBenchmarkCriterion) {
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = redkitchenCorrespondences("fragment_59", "fragment_24");
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  const auto& result = srv.response.result;
  ASSERT_TRUE(result.success) << statusName(result.status) << ": " << result.message;
  const Eigen::Isometry3d truth = readTransformFile(kData + "/redkitchen_24_59/T_target_source_gt.txt");
  EXPECT_LE(rotationErrorDeg(toEigen(result.transform), truth), 15.0);
  EXPECT_LE(translationError(toEigen(result.transform), truth), 0.30);
  EXPECT_EQ(result.header.frame_id, "fragment_59");
  EXPECT_EQ(result.child_frame_id, "fragment_24");
  EXPECT_EQ(result.correspondences, 5678u);
}

// The topic path: correspondences in, ~result out, and the transform on tf.
TEST_F(RegistrationServerTest, CorrespondencesTopicPublishesResultAndTf) {
  mac_registration::RegistrationResultConstPtr received;
  ros::Subscriber sub = nh_.subscribe<mac_registration::RegistrationResult>(
      "/mac_registration/result", 10, [&](const mac_registration::RegistrationResultConstPtr& r) {
        if (r->child_frame_id == "topic_source") received = r;
      });
  waitForPublisher(sub, "/mac_registration/result");
  const TfRecorder sent = recordTf("topic_source");
  ros::Publisher pub = nh_.advertise<mac_registration::Correspondences>("/correspondences", 1, true);
  const auto msg = redkitchenCorrespondences("topic_target", "topic_source");
  pub.publish(msg);
  for (int i = 0; i < 300 && !received; ++i) ros::Duration(0.1).sleep();
  ASSERT_TRUE(received) << "no result on /mac_registration/result";
  ASSERT_TRUE(received->success) << received->message;
  ASSERT_TRUE(waitFor(*sent.latest)) << "no transform on /tf";
  EXPECT_EQ(sent.latest->header.frame_id, "topic_target");
  EXPECT_TRUE(tf2::transformToEigen(*sent.latest).isApprox(toEigen(received->transform), 1e-6));
}

// A zero stamp would put the transform on tf at t = 0, older than any listener's cache: the node stamps the
// result and its tf with the arrival time instead, and says so.
TEST_F(RegistrationServerTest, AZeroStampIsReplacedByTheArrivalTime) {
  const TfRecorder sent = recordTf("zero_stamp_s");
  const ros::Time before = ros::Time::now();
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = redkitchenCorrespondences("zero_stamp_t", "zero_stamp_s");
  srv.request.correspondences.header.stamp = ros::Time(0);
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  const auto& result = srv.response.result;
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_GE(result.header.stamp, before);
  bool said = false;
  for (const auto& w : result.warnings) said |= w.find("header.stamp is zero") != std::string::npos;
  EXPECT_TRUE(said);
  ASSERT_TRUE(waitFor(*sent.latest)) << "no transform on /tf";
  ASSERT_EQ(sent.latest->header.frame_id, "zero_stamp_t");
  EXPECT_EQ(sent.latest->header.stamp, result.header.stamp);
  EXPECT_TRUE(tf2::transformToEigen(*sent.latest).isApprox(toEigen(result.transform), 1e-6));
}

TEST_F(RegistrationServerTest, RegisterServiceAlignsARealScanPair) {
  const auto result = callRegister(redkitchenCloud("source_cloud_bin_4.pcd", "fragment_4"),
                                   redkitchenCloud("target_cloud_bin_0.pcd", "fragment_0"));
  expectWithinBenchmarkCriterion(result);
  EXPECT_GT(result.source_keypoints, 0u);
  EXPECT_GT(result.time_front_end_ms, 0.0);
}

// A loop check's top-k: the right fragment among other places (an outdoor scan and the Stanford bunny,
// each scaled to a room's size) and an empty cloud; the source is described once, the right one comes first.
TEST_F(RegistrationServerTest, RegisterCandidatesPutsTheRightTargetFirst) {
  const auto scaled = [](const std::string& path, float scale, const std::string& frame) {
    PointCloud cloud = *loadCloud(kDemoData + "/" + path);
    for (auto& p : cloud) p.getVector3fMap() *= scale;
    std_msgs::Header header;
    header.frame_id = frame;
    return toPointCloud2(cloud, Eigen::Isometry3d::Identity(), header);
  };
  mac_registration::RegisterCandidates srv;
  srv.request.source = redkitchenCloud("source_cloud_bin_4.pcd", "fragment_4");
  srv.request.targets = {scaled("lidar/lidar_target_251370668.pcd", 0.05f, "street"),
                         scaled("bunny/stanford_bun000.ply", 20.0f, "bunny"),
                         redkitchenCloud("target_cloud_bin_0.pcd", "fragment_0"), sensor_msgs::PointCloud2()};
  ASSERT_TRUE(ros::service::call("/mac_registration/register_candidates", srv));
  const auto& r = srv.response;
  ASSERT_EQ(r.results.size(), 4u) << r.message;
  ASSERT_EQ(r.candidates.size(), 4u);
  EXPECT_EQ(r.candidates[0], 2u);
  expectWithinBenchmarkCriterion(r.results[0]);
  EXPECT_EQ(r.results[0].header.frame_id, "fragment_0");
  EXPECT_EQ(r.results[0].child_frame_id, "fragment_4");
  for (std::size_t k = 1; k < r.results.size(); ++k) EXPECT_FALSE(r.results[k].success) << r.candidates[k];
  for (std::size_t k = 0; k < r.results.size(); ++k) {
    if (r.candidates[k] == 3) {
      EXPECT_EQ(r.results[k].status, mac_registration::RegistrationResult::INVALID_INPUT);
    }
  }
  // Clouds and correspondences at once are refused with a reason, as is nothing at all.
  srv.request.correspondences.resize(1);
  ASSERT_TRUE(ros::service::call("/mac_registration/register_candidates", srv));
  EXPECT_TRUE(srv.response.results.empty());
  EXPECT_NE(srv.response.message.find("not both"), std::string::npos);
  mac_registration::RegisterCandidates nothing;
  ASSERT_TRUE(ros::service::call("/mac_registration/register_candidates", nothing));
  EXPECT_TRUE(nothing.response.results.empty());
  EXPECT_FALSE(nothing.response.message.empty());
}

// The topic path with clouds: a latched target, then a source; ~result, ~aligned and tf must follow.
TEST_F(RegistrationServerTest, CloudTopicsPublishResultAlignedCloudAndTf) {
  mac_registration::RegistrationResultConstPtr received;
  sensor_msgs::PointCloud2ConstPtr aligned;
  ros::Subscriber result_sub = nh_.subscribe<mac_registration::RegistrationResult>(
      "/mac_registration/result", 10, [&](const mac_registration::RegistrationResultConstPtr& r) {
        if (r->child_frame_id == "cloud_topic_source") received = r;
      });
  ros::Subscriber aligned_sub = nh_.subscribe<sensor_msgs::PointCloud2>(
      "/mac_registration/aligned", 1, [&](const sensor_msgs::PointCloud2ConstPtr& c) { aligned = c; });
  ros::Publisher target_pub = nh_.advertise<sensor_msgs::PointCloud2>("/target", 1, true);
  ros::Publisher source_pub = nh_.advertise<sensor_msgs::PointCloud2>("/source", 1, true);
  waitForPublisher(result_sub, "/mac_registration/result");
  waitForPublisher(aligned_sub, "/mac_registration/aligned");
  const TfRecorder sent = recordTf("cloud_topic_source");
  target_pub.publish(redkitchenCloud("target_cloud_bin_0.pcd", "cloud_topic_target"));
  ros::Duration(1.0).sleep();  // the target must be there before the source
  const auto source = redkitchenCloud("source_cloud_bin_4.pcd", "cloud_topic_source");
  source_pub.publish(source);
  for (int i = 0; i < 600 && !(received && aligned); ++i) ros::Duration(0.1).sleep();
  ASSERT_TRUE(received) << "no result on /mac_registration/result";
  expectWithinBenchmarkCriterion(*received);
  ASSERT_TRUE(aligned) << "nothing on /mac_registration/aligned";
  EXPECT_EQ(aligned->header.frame_id, "cloud_topic_target");
  EXPECT_EQ(std::size_t(aligned->width) * aligned->height, std::size_t(source.width) * source.height);
  ASSERT_TRUE(waitFor(*sent.latest)) << "no transform on /tf";
  EXPECT_EQ(sent.latest->header.frame_id, "cloud_topic_target");
  EXPECT_TRUE(tf2::transformToEigen(*sent.latest).isApprox(toEigen(received->transform), 1e-6));
}

TEST_F(RegistrationServerTest, BadCloudsFailWithAReasonAndTheNodeStaysUp) {
  const auto good = xyzCloud({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, "a");
  const float nan = std::numeric_limits<float>::quiet_NaN();

  const auto empty = callRegister(xyzCloud({}, "s"), good);
  EXPECT_FALSE(empty.success);
  EXPECT_NE(empty.message.find("empty"), std::string::npos) << empty.message;

  const auto all_nan = callRegister(xyzCloud({{nan, nan, nan}, {nan, 0, 0}, {0, nan, 0}}, "s"), good);
  EXPECT_FALSE(all_nan.success);
  EXPECT_FALSE(all_nan.message.empty());

  sensor_msgs::PointCloud2 intensity_only;
  intensity_only.header.frame_id = "s";
  sensor_msgs::PointCloud2Modifier modifier(intensity_only);
  modifier.setPointCloud2Fields(1, "intensity", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(10);
  const auto no_xyz = callRegister(intensity_only, good);
  EXPECT_FALSE(no_xyz.success);
  EXPECT_NE(no_xyz.message.find("'x'"), std::string::npos) << no_xyz.message;

  auto truncated = xyzCloud({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, "s");
  truncated.data.resize(truncated.data.size() / 2);  // declares 4 points, carries 2
  const auto short_data = callRegister(truncated, good);
  EXPECT_FALSE(short_data.success);
  EXPECT_NE(short_data.message.find("bytes"), std::string::npos) << short_data.message;

  sensor_msgs::PointCloud2 doubles;
  doubles.header.frame_id = "s";
  sensor_msgs::PointCloud2Modifier double_modifier(doubles);
  double_modifier.setPointCloud2Fields(3, "x", 1, sensor_msgs::PointField::FLOAT64, "y", 1,
                                       sensor_msgs::PointField::FLOAT64, "z", 1,
                                       sensor_msgs::PointField::FLOAT64);
  double_modifier.resize(10);
  const auto float64 = callRegister(doubles, good);
  EXPECT_FALSE(float64.success);
  EXPECT_NE(float64.message.find("float32"), std::string::npos) << float64.message;

  const auto two_points = callRegister(xyzCloud({{0, 0, 0}, {1, 0, 0}}, "s"), good);
  EXPECT_FALSE(two_points.success);
  EXPECT_FALSE(two_points.message.empty());

  // Still answering, and still registering.
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = redkitchenCorrespondences("after_t", "after_s");
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  EXPECT_TRUE(srv.response.result.success) << srv.response.result.message;
}

TEST_F(RegistrationServerTest, MismatchedCorrespondencesFailWithAReason) {
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = redkitchenCorrespondences("t", "s");
  srv.request.correspondences.target_points.pop_back();
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  EXPECT_FALSE(srv.response.result.success);
  EXPECT_EQ(srv.response.result.status, mac_registration::RegistrationResult::INVALID_INPUT);
  // Identity, never garbage, on failure.
  EXPECT_TRUE(toEigen(srv.response.result.transform).isApprox(Eigen::Isometry3d::Identity()));
}

// dynamic_reconfigure changes thresholds live. The real set's inliers lie within 10 cm of the truth, not
// within 1 mm: a 1 mm inlier threshold must find only a handful; requiring 300 inliers (it has ~226) must
// fail; the defaults must bring the full result back.
TEST_F(RegistrationServerTest, ReconfiguredThresholdsApplyToTheNextRegistration) {
  const auto reconfigure = [](double inlier_threshold, int min_inliers) {
    dynamic_reconfigure::Reconfigure srv;
    dynamic_reconfigure::DoubleParameter tau;
    tau.name = "evaluation_inlier_threshold";
    tau.value = inlier_threshold;
    dynamic_reconfigure::IntParameter count;
    count.name = "evaluation_min_inliers";
    count.value = min_inliers;
    srv.request.config.doubles.push_back(tau);
    srv.request.config.ints.push_back(count);
    EXPECT_TRUE(ros::service::call("/mac_registration/set_parameters", srv));
  };
  const auto registerRealSet = [] {
    mac_registration::RegisterCorrespondences srv;
    srv.request.correspondences = redkitchenCorrespondences("reconfigure_t", "reconfigure_s");
    EXPECT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
    return srv.response.result;
  };
  reconfigure(0.001, 3);
  const auto strict = registerRealSet();
  EXPECT_LT(strict.inliers, 20u) << strict.message;
  reconfigure(0.1, 300);
  const auto demanding = registerRealSet();
  EXPECT_FALSE(demanding.success);
  EXPECT_EQ(demanding.status, mac_registration::RegistrationResult::TOO_FEW_INLIERS) << demanding.message;
  int min_inliers = 0;
  EXPECT_TRUE(ros::param::get("/mac_registration/evaluation/min_inliers", min_inliers));
  EXPECT_EQ(min_inliers, 300);  // the private parameter follows the reconfiguration
  reconfigure(0.1, 3);
  const auto normal = registerRealSet();
  EXPECT_TRUE(normal.success) << normal.message;
  EXPECT_GT(normal.inliers, 150u);
}

// Out-of-range values are refused, not clamped into range: dynamic_reconfigure's answer (what rqt and
// dynparam show) keeps the values in force, and so do the registrations.
TEST_F(RegistrationServerTest, OutOfRangeReconfigurationsAreRefusedNotClamped) {
  const auto reconfigure = [](const std::string& name, double value, bool integer) {
    dynamic_reconfigure::Reconfigure srv;
    if (integer) {
      dynamic_reconfigure::IntParameter p;
      p.name = name;
      p.value = static_cast<int>(value);
      srv.request.config.ints.push_back(p);
    } else {
      dynamic_reconfigure::DoubleParameter p;
      p.name = name;
      p.value = value;
      srv.request.config.doubles.push_back(p);
    }
    EXPECT_TRUE(ros::service::call("/mac_registration/set_parameters", srv));
    return srv.response.config;
  };
  const auto doubleValue = [](const dynamic_reconfigure::Config& config, const std::string& name) {
    for (const auto& p : config.doubles) {
      if (p.name == name) return p.value;
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  const auto intValue = [](const dynamic_reconfigure::Config& config, const std::string& name) {
    for (const auto& p : config.ints) {
      if (p.name == name) return p.value;
    }
    return -1;
  };
  EXPECT_DOUBLE_EQ(doubleValue(reconfigure("graph_t_cmp", 1.5, false), "graph_t_cmp"), 0.99);
  EXPECT_DOUBLE_EQ(
      doubleValue(reconfigure("evaluation_inlier_threshold", -0.2, false), "evaluation_inlier_threshold"),
      0.1);
  EXPECT_EQ(intValue(reconfigure("evaluation_min_inliers", 1, true), "evaluation_min_inliers"), 3);
  // The private parameters the node reads at start say what is in force too.
  double t_cmp = 0.0;
  EXPECT_TRUE(ros::param::get("/mac_registration/graph/t_cmp", t_cmp));
  EXPECT_DOUBLE_EQ(t_cmp, 0.99);

  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = redkitchenCorrespondences("refused_t", "refused_s");
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  EXPECT_TRUE(srv.response.result.success) << srv.response.result.message;
  EXPECT_GT(srv.response.result.inliers, 150u);
}

// /diagnostics reports the registrations the node made.
TEST_F(RegistrationServerTest, DiagnosticsCountRegistrations) {
  mac_registration::RegisterCorrespondences srv;
  srv.request.correspondences = redkitchenCorrespondences("diag_t", "diag_s");
  ASSERT_TRUE(ros::service::call("/mac_registration/register_correspondences", srv));
  diagnostic_msgs::DiagnosticArrayConstPtr received;
  ros::Subscriber sub = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& d) {
        for (const auto& status : d->status) {
          if (status.name.find("registration") != std::string::npos) received = d;
        }
      });
  for (int i = 0; i < 50 && !received; ++i) ros::Duration(0.1).sleep();  // the updater publishes at 1 Hz
  ASSERT_TRUE(received) << "no registration status on /diagnostics";
  bool counted = false;
  for (const auto& status : received->status) {
    for (const auto& kv : status.values) counted |= kv.key == "registrations" && std::stoul(kv.value) > 0;
  }
  EXPECT_TRUE(counted);
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_registration_server");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
