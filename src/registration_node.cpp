// The standalone node: loads the nodelet in-process, so `rosrun mac_registration registration_node` and a
// nodelet manager run the same code, parameter checks and log lines included.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "mac_registration");
  // Held for the life of the process: when the last NodeHandle goes, roscpp shuts down, and rosconsole
  // with it, for good.
  ros::NodeHandle nh;
  nodelet::Loader loader(false);  // no load/unload services: this process runs one nodelet
  nodelet::M_string remappings(ros::names::getRemappings().begin(), ros::names::getRemappings().end());
  nodelet::V_string arguments(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "mac_registration/RegistrationNodelet", remappings,
                   arguments)) {
    // The nodelet has logged why (invalid parameters, each named); standalone, refusing means exiting.
    ROS_FATAL("mac_registration: %s not started", ros::this_node::getName().c_str());
    return 1;
  }
  ros::spin();
  return 0;
}
