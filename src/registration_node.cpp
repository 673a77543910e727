// The standalone node: loads the nodelet in-process, so `rosrun mac_registration registration_node` and a
// nodelet manager run the same code.
#include <nodelet/loader.h>
#include <ros/ros.h>

#include "mac_registration/ros/server_config.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "mac_registration");
  // The nodelet refuses invalid parameters without stopping its manager; standalone, refusing means exiting.
  mac_registration::ServerConfig config;
  const auto problems = mac_registration::loadServerConfig(ros::NodeHandle("~"), config);
  if (!problems.empty()) {
    for (const auto& problem : problems) ROS_FATAL("mac_registration: %s", problem.c_str());
    return 1;
  }
  nodelet::Loader loader;
  nodelet::M_string remappings(ros::names::getRemappings().begin(), ros::names::getRemappings().end());
  nodelet::V_string arguments(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "mac_registration/RegistrationNodelet", remappings,
                   arguments)) {
    ROS_FATAL("mac_registration: could not load mac_registration/RegistrationNodelet");
    return 1;
  }
  ros::spin();
  return 0;
}
