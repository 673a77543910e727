// Starting, against a real nodelet manager and real node processes (test/ros/lifecycle.test): invalid
// parameters refuse a nodelet (the manager lives on, `nodelet load` fails) and make the standalone node say
// why and exit; the node logs.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <mac_registration/RegisterCorrespondences.h>
#include <nodelet/NodeletList.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mac_registration/core/text_io.hpp"
#include "mac_registration/ros/conversions.hpp"

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

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lifecycle");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
