// Starting and stopping, against a real nodelet manager and real node processes (test/ros/lifecycle.test):
// invalid parameters refuse a nodelet (the manager lives on, `nodelet load` fails) and make the standalone
// node say why and exit; the node logs; unloading the nodelet, interrupting the node or `rosnode kill` ends
// a long registration (in the clique search, or describing a 5 M-point target) within a second, and the
// call in progress gets its CANCELLED result.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <mac_registration/Register.h>
#include <mac_registration/RegisterCorrespondences.h>
#include <nodelet/NodeletList.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/ros/conversions.hpp"
#include "xyz_cloud.hpp"

extern char** environ;

namespace mac_registration {
namespace {

const std::string kManager = "/lifecycle_manager";
const std::string kType = "mac_registration/RegistrationNodelet";

// A command's exit status and everything it printed; `timeout` guards against a command that hangs.
struct CommandResult {
  int exit_status = -1;
  std::string output;
};

CommandResult runCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen(("timeout 120 " + command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) result.output += buffer;
  const int status = pclose(pipe);
  result.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A child process (rosrun execs the node, so the pid is the node's) with its output in a file.
class NodeProcess {
 public:
  NodeProcess(const std::vector<std::string>& args, const std::string& log_path) : log_path_(log_path) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (posix_spawnp(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~NodeProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  bool started() const { return pid_ > 0; }
  void interrupt() const { kill(pid_, SIGINT); }
  // Waits up to `limit` for the process to end; false if it did not (it is killed at destruction).
  bool waitForExit(ros::WallDuration limit) {
    const ros::WallTime deadline = ros::WallTime::now() + limit;
    while (ros::WallTime::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        return true;
      }
      ros::WallDuration(0.01).sleep();
    }
    return false;
  }
  int exitStatus() const { return exit_status_; }
  std::string output() const { return readFile(log_path_); }

 private:
  std::string log_path_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int exit_status_ = -1;
};

std::vector<std::string> loadedNodelets() {
  nodelet::NodeletList list;
  EXPECT_TRUE(ros::service::call(kManager + "/list", list)) << "the manager does not answer";
  return list.response.nodelets;
}

bool isLoaded(const std::string& name) {
  const auto names = loadedNodelets();
  return std::find(names.begin(), names.end(), name) != names.end();
}

// [s] How long a stop (SIGINT, rosnode kill, an unload) may take to end the process or the nodelet, the
// call in progress answered.
constexpr double kStopWithin = 1.0;

bool loadNodelet(const std::string& name) {
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = kType;
  return ros::service::call(kManager + "/load_nodelet", load) && load.response.success;
}

TEST(Lifecycle, InvalidParametersRefuseTheNodeletAndSpareTheManager) {
  ASSERT_TRUE(ros::service::waitForService(kManager + "/load_nodelet", ros::Duration(60.0)));
  ros::param::set("/refused/graph/t_cmp", 1.5);
  EXPECT_FALSE(loadNodelet("/refused"));
  EXPECT_FALSE(isLoaded("/refused"));

  // The command roslaunch runs for a nodelet fails too, so that roslaunch sees it.
  const auto load = runCommand("rosrun nodelet nodelet load " + kType + " " + kManager +
                               " __name:=refused_too _graph/t_cmp:=1.5 --no-bond");
  EXPECT_NE(load.exit_status, 0) << load.output;
  EXPECT_NE(load.exit_status, 124) << "nodelet load did not end:\n" << load.output;
  EXPECT_FALSE(isLoaded("/refused_too"));

  // The manager still loads and unloads a valid one.
  EXPECT_TRUE(loadNodelet("/accepted"));
  EXPECT_TRUE(isLoaded("/accepted"));
  nodelet::NodeletUnload unload;
  unload.request.name = "/accepted";
  EXPECT_TRUE(ros::service::call(kManager + "/unload_nodelet", unload) && unload.response.success);
}

TEST(Lifecycle, TheNodeNamesInvalidParametersAndExits) {
  const auto node =
      runCommand("rosrun mac_registration registration_node __name:=invalid_node _graph/t_cmp:=1.5");
  EXPECT_NE(node.exit_status, 0) << node.output;
  EXPECT_NE(node.exit_status, 124) << "the node did not exit:\n" << node.output;
  EXPECT_NE(node.output.find("graph.t_cmp = 1.5 is out of range"), std::string::npos) << node.output;
}

TEST(Lifecycle, TheNodeLogsItsConfigurationAndEachRegistration) {
  NodeProcess node({"rosrun", "mac_registration", "registration_node", "__name:=logging_node"},
                   "/tmp/mac_registration_logging_node.log");
  ASSERT_TRUE(node.started());
  ASSERT_TRUE(ros::service::waitForService("/logging_node/register_correspondences", ros::Duration(60.0)));
  mac_registration::RegisterCorrespondences srv;
  std_msgs::Header header;
  header.frame_id = "log_target";
  header.stamp = ros::Time::now();
  srv.request.correspondences = toCorrespondencesMsg(
      readCorrespondencesFile(std::string(MAC_TEST_DATA_DIR) + "/redkitchen_24_59/correspondences.txt"),
      header, "log_source");
  ASSERT_TRUE(ros::service::call("/logging_node/register_correspondences", srv));
  ASSERT_TRUE(srv.response.result.success) << srv.response.result.message;
  node.interrupt();
  ASSERT_TRUE(node.waitForExit(ros::WallDuration(60.0)));
  EXPECT_EQ(node.exitStatus(), 0);
  const std::string log = node.output();
  EXPECT_NE(log.find("effective configuration (/logging_node)"), std::string::npos) << log;
  EXPECT_NE(log.find("log_target <- log_source"), std::string::npos) << log;
}

// The parameters of a registration that runs for 20 s unless it is stopped: no bound on the clique search
// but its time.
void setLongRegistrationParams(const std::string& ns) {
  ros::param::set(ns + "/cliques/time_limit", 20.0);
  ros::param::set(ns + "/cliques/max_degeneracy", 0);
  ros::param::set(ns + "/cliques/max_cliques", 1000000000);
  ros::param::set(ns + "/cliques/max_pruning_rounds", 0);
}

// 8000 correspondences in a 10 m cube, half of them one rigid motion with 5 mm noise: a graph dense enough
// for the clique search to use all of its time.
mac_registration::Correspondences denseCorrespondences() {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> coordinate(-5.0, 5.0);
  std::normal_distribution<double> noise(0.0, 0.005);
  CorrespondenceSet set;
  const int n = 8000;
  set.source_points.resize(3, n);
  set.target_points.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d s(coordinate(random), coordinate(random), coordinate(random));
    const Eigen::Vector3d t =
        i % 2 == 0 ? Eigen::Vector3d(s + Eigen::Vector3d(1.0, noise(random), noise(random)))
                   : Eigen::Vector3d(coordinate(random), coordinate(random), coordinate(random));
    set.source_points.col(i) = s;
    set.target_points.col(i) = t;
  }
  std_msgs::Header header;
  header.frame_id = "long_target";
  header.stamp = ros::Time::now();
  return toCorrespondencesMsg(set, header, "long_source");
}

// The call runs in its own thread; the result says whether it came back and with what.
struct PendingCall {
  std::future<std::pair<bool, mac_registration::RegistrationResult>> result;
};

PendingCall callLongRegistration(const std::string& service) {
  PendingCall call;
  call.result = std::async(std::launch::async, [service] {
    mac_registration::RegisterCorrespondences srv;
    srv.request.correspondences = denseCorrespondences();
    const bool answered = ros::service::call(service, srv);
    return std::make_pair(answered, srv.response.result);
  });
  return call;
}

// Two matches, too few for a registration: a call or topic input that fails at once, before the igraph
// part (which a long registration holds).
mac_registration::Correspondences tinyCorrespondences(const std::string& source_frame) {
  CorrespondenceSet set;
  set.source_points = Eigen::Matrix3Xd::Random(3, 2);
  set.target_points = set.source_points;
  std_msgs::Header header;
  header.frame_id = "tiny_target";
  header.stamp = ros::Time::now();
  return toCorrespondencesMsg(set, header, source_frame);
}

// The latest registration status the nodelet put on /diagnostics.
class DiagnosticsWatch {
 public:
  explicit DiagnosticsWatch(ros::NodeHandle& nh)
      : sub_(nh.subscribe<diagnostic_msgs::DiagnosticArray>(
            "/diagnostics", 10, [this](const diagnostic_msgs::DiagnosticArrayConstPtr& array) {
              for (const auto& status : array->status) {
                if (status.name.find("registration") == std::string::npos) continue;
                std::lock_guard<std::mutex> lock(mutex_);
                for (const auto& kv : status.values) values_[kv.key] = kv.value;
                ++received_;
              }
            })) {}
  std::size_t received() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }
  std::string value(const std::string& key) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = values_.find(key);
    return it == values_.end() ? std::string() : it->second;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::string> values_;
  std::size_t received_ = 0;
  ros::Subscriber sub_;
};

// A long call runs on the service threads: another call, the topics and the diagnostics go on meanwhile.
// Then the unload, which raises the stop flag, answers once the registration has stopped.
TEST(Lifecycle, ALongCallHoldsUpNothingAndUnloadingStopsIt) {
  ASSERT_TRUE(ros::service::waitForService(kManager + "/load_nodelet", ros::Duration(60.0)));
  setLongRegistrationParams("/long");
  ASSERT_TRUE(loadNodelet("/long"));
  ASSERT_TRUE(ros::service::waitForService("/long/register_correspondences", ros::Duration(30.0)));
  ros::NodeHandle nh;
  mac_registration::RegistrationResultConstPtr topic_result;
  std::mutex topic_mutex;
  ros::Subscriber result_sub = nh.subscribe<mac_registration::RegistrationResult>(
      "/long/result", 10, [&](const mac_registration::RegistrationResultConstPtr& r) {
        std::lock_guard<std::mutex> lock(topic_mutex);
        if (r->child_frame_id == "tiny_topic") topic_result = r;
      });
  ros::Publisher pub = nh.advertise<mac_registration::Correspondences>("/correspondences", 10);
  DiagnosticsWatch diagnostics(nh);
  const auto running = [](PendingCall& call) {
    return call.result.wait_for(std::chrono::seconds(0)) == std::future_status::timeout;
  };

  auto call = callLongRegistration("/long/register_correspondences");
  ros::WallDuration(3.0).sleep();  // well inside the clique search
  ASSERT_TRUE(running(call)) << "the registration ended before the checks";

  mac_registration::RegisterCorrespondences other;
  other.request.correspondences = tinyCorrespondences("tiny_call");
  ASSERT_TRUE(ros::service::call("/long/register_correspondences", other));
  EXPECT_FALSE(other.response.result.success);
  EXPECT_TRUE(running(call)) << "the second call was answered only after the first";

  for (int i = 0; i < 50 && pub.getNumSubscribers() == 0; ++i) ros::WallDuration(0.1).sleep();
  pub.publish(tinyCorrespondences("tiny_topic"));
  const std::size_t diagnostics_before = diagnostics.received();
  bool topic_answered = false;
  for (int i = 0; i < 50 && !(topic_answered && diagnostics.received() > diagnostics_before); ++i) {
    ros::WallDuration(0.1).sleep();
    std::lock_guard<std::mutex> lock(topic_mutex);
    topic_answered = topic_result != nullptr;
  }
  EXPECT_TRUE(topic_answered) << "no ~result for the topic input during the call";
  EXPECT_GT(diagnostics.received(), diagnostics_before) << "no /diagnostics during the call";
  EXPECT_TRUE(running(call)) << "the checks outlasted the registration: they prove nothing";

  const ros::WallTime start = ros::WallTime::now();
  nodelet::NodeletUnload unload;
  unload.request.name = "/long";
  EXPECT_TRUE(ros::service::call(kManager + "/unload_nodelet", unload) && unload.response.success);
  const double unload_s = (ros::WallTime::now() - start).toSec();
  ASSERT_EQ(call.result.wait_for(std::chrono::seconds(60)), std::future_status::ready);
  const auto [answered, result] = call.result.get();
  const double call_s = (ros::WallTime::now() - start).toSec();
  RecordProperty("unload_seconds", std::to_string(unload_s));
  std::printf("unload during a registration: %.2f s (the call returned after %.2f s: %s)\n", unload_s, call_s,
              answered ? statusName(result.status).c_str() : "no answer");
  EXPECT_LT(unload_s, kStopWithin);
  ASSERT_TRUE(answered) << "the call got a transport error instead of its result";
  EXPECT_EQ(result.status, mac_registration::RegistrationResult::CANCELLED) << result.message;
  EXPECT_FALSE(isLoaded("/long"));  // and the manager still answers
}

// Inputs that arrive while the worker registers replace each other in its slot; each replaced one is
// counted on /diagnostics (none vanishes uncounted in roscpp's queue).
TEST(Lifecycle, InputsReplacedWhileTheWorkerIsBusyAreCounted) {
  ASSERT_TRUE(ros::service::waitForService(kManager + "/load_nodelet", ros::Duration(60.0)));
  setLongRegistrationParams("/busy");
  ASSERT_TRUE(loadNodelet("/busy"));
  ASSERT_TRUE(ros::service::waitForService("/busy/register_correspondences", ros::Duration(30.0)));
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<mac_registration::Correspondences>("/correspondences", 10);
  DiagnosticsWatch diagnostics(nh);
  for (int i = 0; i < 50 && pub.getNumSubscribers() == 0; ++i) ros::WallDuration(0.1).sleep();
  ASSERT_GT(pub.getNumSubscribers(), 0u);

  pub.publish(denseCorrespondences());
  ros::WallDuration(2.0).sleep();  // the worker has taken it and is registering
  const int replaced = 4;
  for (int i = 0; i <= replaced; ++i) pub.publish(tinyCorrespondences("burst_" + std::to_string(i)));
  bool counted = false;
  for (int i = 0; i < 100 && !counted; ++i) {
    ros::WallDuration(0.1).sleep();
    counted = diagnostics.value("inputs dropped (worker busy)") == std::to_string(replaced);
  }
  EXPECT_TRUE(counted) << "inputs dropped (worker busy) = '"
                       << diagnostics.value("inputs dropped (worker busy)") << "', expected " << replaced;

  nodelet::NodeletUnload unload;
  unload.request.name = "/busy";
  EXPECT_TRUE(ros::service::call(kManager + "/unload_nodelet", unload) && unload.response.success);
}

// SIGINT (what roslaunch sends first): roscpp's shutdown raises the stop flag and the node exits.
TEST(Lifecycle, InterruptingTheNodeStopsALongRegistration) {
  NodeProcess node(
      {"rosrun", "mac_registration", "registration_node", "__name:=long_node", "_cliques/time_limit:=20.0",
       "_cliques/max_degeneracy:=0", "_cliques/max_cliques:=1000000000", "_cliques/max_pruning_rounds:=0"},
      "/tmp/mac_registration_long_node.log");
  ASSERT_TRUE(node.started());
  ASSERT_TRUE(ros::service::waitForService("/long_node/register_correspondences", ros::Duration(60.0)));
  auto call = callLongRegistration("/long_node/register_correspondences");
  ros::WallDuration(3.0).sleep();
  ASSERT_EQ(call.result.wait_for(std::chrono::seconds(0)), std::future_status::timeout)
      << "the registration ended before the interrupt";
  const ros::WallTime start = ros::WallTime::now();
  node.interrupt();
  ASSERT_TRUE(node.waitForExit(ros::WallDuration(60.0))) << node.output();
  const double exit_s = (ros::WallTime::now() - start).toSec();
  ASSERT_EQ(call.result.wait_for(std::chrono::seconds(60)), std::future_status::ready);
  const auto [answered, result] = call.result.get();
  RecordProperty("sigint_exit_seconds", std::to_string(exit_s));
  std::printf("SIGINT during a registration: the node exited after %.2f s (the call: %s)\n", exit_s,
              answered ? statusName(result.status).c_str() : "no answer");
  EXPECT_EQ(node.exitStatus(), 0) << node.output();
  EXPECT_LT(exit_s, kStopWithin);
  ASSERT_TRUE(answered) << "the call got a transport error instead of its result";
  EXPECT_EQ(result.status, mac_registration::RegistrationResult::CANCELLED) << result.message;
}

// ~5 M points: the shipped scan 0 tiled 19 x 19 times, 5 m apart, each copy jittered by up to 1 mm. Each
// copy keeps its ~4 000 keypoints, so describing it (a voxel grid over 5 M points, then normals and FPFH
// of 1.5 M keypoints) takes tens of seconds on two cores unless a stop ends it.
sensor_msgs::PointCloud2 hugeTarget() {
  const PointCloud::Ptr scan =
      loadCloud(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/target_cloud_bin_0.pcd");
  std::mt19937 random(3);
  std::uniform_real_distribution<float> jitter(-0.001f, 0.001f);
  const int tiles = 19;
  std::vector<Eigen::Vector3f> points;
  points.reserve(std::size_t(tiles) * tiles * scan->size());
  for (int i = 0; i < tiles; ++i) {
    for (int j = 0; j < tiles; ++j) {
      const Eigen::Vector3f offset(5.0f * i, 5.0f * j, 0.0f);
      for (const auto& p : *scan) {
        points.push_back(p.getVector3fMap() + offset + Eigen::Vector3f(jitter(random), jitter(random), 0.0f));
      }
    }
  }
  return test::xyzCloud(points, "huge_target");
}

// Started with the huge target in the request: its call is still in the target's description seconds later.
std::future<std::pair<bool, mac_registration::RegistrationResult>> callWithHugeTarget(
    const std::string& service) {
  auto request = std::make_shared<mac_registration::Register::Request>();
  request->target = hugeTarget();
  request->source =
      toPointCloud2(*loadCloud(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd"),
                    Eigen::Isometry3d::Identity(), std_msgs::Header());
  request->source.header.frame_id = "small_source";
  return std::async(std::launch::async, [service, request] {
    mac_registration::Register srv;
    srv.request = std::move(*request);
    const bool answered = ros::service::call(service, srv);
    return std::make_pair(answered, srv.response.result);
  });
}

// Long enough after the call for the node to have received the 80 MB request and be describing it (the
// voxel grid takes ~1 s of it, normals and FPFH tens), whatever else loads the machine.
constexpr double kIntoTheDescription = 5.0;

// The call is answered with CANCELLED, by a registration stopped while it described the target.
void expectCancelledInTheDescription(bool answered, const mac_registration::RegistrationResult& result) {
  ASSERT_TRUE(answered) << "the call got a transport error instead of its result";
  EXPECT_EQ(result.status, mac_registration::RegistrationResult::CANCELLED) << result.message;
  EXPECT_NE(result.message.find("describing the target cloud"), std::string::npos) << result.message;
}

// What `rosnode kill NAME` does: the node's XML-RPC `shutdown`, at the address the master gives for it.
bool killNode(const std::string& name) {
  XmlRpc::XmlRpcValue request, response, payload;
  request[0] = ros::this_node::getName();
  request[1] = name;
  if (!ros::master::execute("lookupNode", request, response, payload, false)) return false;
  std::string host;
  std::uint32_t port = 0;
  if (!ros::network::splitURI(static_cast<std::string>(payload), host, port)) return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue params, result;
  params[0] = ros::this_node::getName();
  params[1] = "test_lifecycle: rosnode kill";
  return client.execute("shutdown", params, result) && !client.isFault();
}

// A standalone node stopped (by `stop`) while it describes a huge target: it exits within a second and the
// call gets its CANCELLED result first.
void expectNodeStoppedInTheDescription(const std::string& name,
                                       const std::function<void(NodeProcess&)>& stop) {
  NodeProcess node({"rosrun", "mac_registration", "registration_node", "__name:=" + name},
                   "/tmp/mac_registration_" + name + ".log");
  ASSERT_TRUE(node.started());
  ASSERT_TRUE(ros::service::waitForService("/" + name + "/register", ros::Duration(60.0)));
  auto call = callWithHugeTarget("/" + name + "/register");
  ASSERT_EQ(call.wait_for(std::chrono::duration<double>(kIntoTheDescription)), std::future_status::timeout)
      << "the registration ended before the stop";
  const ros::WallTime start = ros::WallTime::now();
  stop(node);
  ASSERT_TRUE(node.waitForExit(ros::WallDuration(60.0))) << node.output();
  const double exit_s = (ros::WallTime::now() - start).toSec();
  ASSERT_EQ(call.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  const auto [answered, result] = call.get();
  std::printf("%s during a description: the node exited after %.2f s (the call: %s)\n", name.c_str(), exit_s,
              answered ? (statusName(result.status) + ": " + result.message).c_str() : "no answer");
  EXPECT_EQ(node.exitStatus(), 0) << node.output();
  EXPECT_LT(exit_s, kStopWithin);
  expectCancelledInTheDescription(answered, result);
}

TEST(Lifecycle, InterruptingTheNodeStopsTheDescriptionOfAHugeTarget) {
  expectNodeStoppedInTheDescription("interrupted_node", [](NodeProcess& node) { node.interrupt(); });
}

TEST(Lifecycle, RosnodeKillStopsTheDescriptionOfAHugeTarget) {
  expectNodeStoppedInTheDescription("killed_node",
                                    [](NodeProcess&) { ASSERT_TRUE(killNode("/killed_node")); });
}

TEST(Lifecycle, UnloadingTheNodeletStopsTheDescriptionOfAHugeTarget) {
  ASSERT_TRUE(ros::service::waitForService(kManager + "/load_nodelet", ros::Duration(60.0)));
  ASSERT_TRUE(loadNodelet("/describing"));
  ASSERT_TRUE(ros::service::waitForService("/describing/register", ros::Duration(30.0)));
  auto call = callWithHugeTarget("/describing/register");
  ASSERT_EQ(call.wait_for(std::chrono::duration<double>(kIntoTheDescription)), std::future_status::timeout)
      << "the registration ended before the unload";
  const ros::WallTime start = ros::WallTime::now();
  nodelet::NodeletUnload unload;
  unload.request.name = "/describing";
  EXPECT_TRUE(ros::service::call(kManager + "/unload_nodelet", unload) && unload.response.success);
  const double unload_s = (ros::WallTime::now() - start).toSec();
  ASSERT_EQ(call.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  const auto [answered, result] = call.get();
  std::printf("unload during a description: %.2f s (the call: %s)\n", unload_s,
              answered ? (statusName(result.status) + ": " + result.message).c_str() : "no answer");
  EXPECT_LT(unload_s, kStopWithin);
  expectCancelledInTheDescription(answered, result);
  EXPECT_FALSE(isLoaded("/describing"));
}

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lifecycle");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
