// Concurrent ~register calls against a real nodelet (test/ros/concurrent_calls.test): more calls at once than
// the node has service threads, on the shipped pair (redkitchen fragments 4 -> 0). Each must get the answer
// a call alone gets, bit for bit: the clique searches of concurrent calls queue for igraph, and neither
// that wait nor the other calls' work on the cores may cut a search short.
#include <gtest/gtest.h>
#include <mac_registration/Register.h>
#include <ros/ros.h>

#include <algorithm>
#include <cstdio>
#include <future>
#include <string>
#include <utility>
#include <vector>

#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {
namespace {

const std::string kService = "/mac_registration/register";

sensor_msgs::PointCloud2 shippedCloud(const std::string& file, const std::string& frame) {
  std_msgs::Header header;
  header.frame_id = frame;
  return toPointCloud2(*loadCloud(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/" + file),
                       Eigen::Isometry3d::Identity(), header);
}

struct Answer {
  bool answered = false;
  mac_registration::RegistrationResult result;
  double seconds = 0.0;  // the call's round trip
};

Answer callRegister(const sensor_msgs::PointCloud2& source, const sensor_msgs::PointCloud2& target) {
  mac_registration::Register srv;
  srv.request.source = source;
  srv.request.target = target;
  const ros::WallTime start = ros::WallTime::now();
  Answer answer;
  answer.answered = ros::service::call(kService, srv);
  answer.seconds = (ros::WallTime::now() - start).toSec();
  answer.result = srv.response.result;
  return answer;
}

bool sameTransform(const geometry_msgs::Transform& a, const geometry_msgs::Transform& b) {
  return a.translation.x == b.translation.x && a.translation.y == b.translation.y &&
         a.translation.z == b.translation.z && a.rotation.x == b.rotation.x && a.rotation.y == b.rotation.y &&
         a.rotation.z == b.rotation.z && a.rotation.w == b.rotation.w;
}

TEST(ConcurrentCalls, EveryCallGetsTheAnswerOfACallAlone) {
  ASSERT_TRUE(ros::service::waitForService(kService, ros::Duration(60.0)));
  int service_threads = 0;
  ASSERT_TRUE(ros::param::get("/mac_registration/service_threads", service_threads));
  const sensor_msgs::PointCloud2 source = shippedCloud("source_cloud_bin_4.pcd", "fragment_4");
  const sensor_msgs::PointCloud2 target = shippedCloud("target_cloud_bin_0.pcd", "fragment_0");

  const Answer alone = callRegister(source, target);
  ASSERT_TRUE(alone.answered);
  ASSERT_TRUE(alone.result.success) << statusName(alone.result.status) << ": " << alone.result.message;
  // Alone, the search fits its budget: a bounded one would make the comparison below meaningless.
  ASSERT_TRUE(alone.result.clique_search_complete);
  ASSERT_GT(alone.result.cliques, 10000u) << "too small a clique search to make the calls wait for igraph";

  // Calls in pairs reach their clique searches together, and one waits for the other's: five rounds of it.
  const int calls = 5 * service_threads;
  std::vector<std::future<Answer>> pending;
  for (int i = 0; i < calls; ++i) {
    pending.push_back(std::async(std::launch::async, [&] { return callRegister(source, target); }));
  }
  double slowest = 0.0;
  for (int i = 0; i < calls; ++i) {
    const Answer answer = pending[i].get();
    slowest = std::max(slowest, answer.seconds);
    ASSERT_TRUE(answer.answered) << "call " << i;
    const auto& r = answer.result;
    EXPECT_TRUE(r.success) << "call " << i << ": " << statusName(r.status) << ": " << r.message;
    EXPECT_TRUE(r.clique_search_complete) << "call " << i << ": the clique search was cut short";
    EXPECT_EQ(r.inliers, alone.result.inliers) << "call " << i;
    EXPECT_EQ(r.cliques, alone.result.cliques) << "call " << i;
    EXPECT_TRUE(sameTransform(r.transform, alone.result.transform)) << "call " << i;
  }
  // The calls ran side by side on the service threads: the last answer came after several registrations.
  std::printf(
      "%d concurrent calls on %d service threads: the slowest took %.2f s, one alone %.2f s (clique search "
      "%.0f ms of cliques.time_limit = 0.8 s)\n",
      calls, service_threads, slowest, alone.seconds, alone.result.time_clique_search_ms);
  EXPECT_GT(slowest, 1.5 * alone.seconds);
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_concurrent_calls");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
