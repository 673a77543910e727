// The standalone nodes: each loads its nodelet in-process (MAC_NODELET_TYPE: registration_node the
// registration nodelet, relocalization_node the relocalization one), so `rosrun mac_registration
// registration_node` and a nodelet manager run the same code, parameter checks and log lines included.
#include <nodelet/loader.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/xmlrpc_manager.h>

#include <atomic>
#include <csignal>

namespace {

// Set by SIGINT, SIGTERM and `rosnode kill`; read by the main loop. Lock-free, so a signal handler may
// set it.
std::atomic<bool> g_stop_requested{false};

void onSignal(int) { g_stop_requested = true; }

// roscpp's answer to the XML-RPC `shutdown` call (rosnode kill, or the master replacing a node of the same
// name) shuts roscpp down at once from its own thread. This one only asks the main loop to stop, and
// answers as roscpp does.
void onShutdownCall(XmlRpc::XmlRpcValue& params, XmlRpc::XmlRpcValue& result) {
  if (params.getType() == XmlRpc::XmlRpcValue::TypeArray && params.size() > 1) {
    ROS_WARN_STREAM("mac_registration: shutdown requested: " << static_cast<std::string>(params[1]));
  }
  g_stop_requested = true;
  result = ros::xmlrpc::responseInt(1, "", 0);
}

}  // namespace

int main(int argc, char** argv) {
  // roscpp's own SIGINT handling and shutdown call close every connection first, those of the service
  // calls in progress included, whose callers then get a transport error instead of their CANCELLED
  // result. Here the nodelet is unloaded first (its registrations stop, the calls in progress are
  // answered) and roscpp shut down after.
  ros::init(argc, argv, "mac_registration", ros::init_options::NoSigintHandler);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  // Held for the life of the process: when the last NodeHandle goes, roscpp shuts down, and rosconsole
  // with it, for good.
  ros::NodeHandle nh;
  const ros::XMLRPCManagerPtr xmlrpc = ros::XMLRPCManager::instance();
  xmlrpc->unbind("shutdown");
  xmlrpc->bind("shutdown", onShutdownCall);

  nodelet::Loader loader(false);  // no load/unload services: this process runs one nodelet
  nodelet::M_string remappings(ros::names::getRemappings().begin(), ros::names::getRemappings().end());
  nodelet::V_string arguments(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), MAC_NODELET_TYPE, remappings, arguments)) {
    // The nodelet has logged why (invalid parameters, each named); standalone, refusing means exiting.
    ROS_FATAL("mac_registration: %s not started", ros::this_node::getName().c_str());
    return 1;
  }
  // ros::spin() on the global queue, until a stop is asked for or roscpp shuts down by itself.
  while (ros::ok() && !g_stop_requested) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
  }
  // Unloading raises the nodelet's stop flag and returns once the service calls in progress have been
  // answered (CANCELLED); only then may roscpp close their connections.
  loader.clear();
  ros::shutdown();
  return 0;
}
