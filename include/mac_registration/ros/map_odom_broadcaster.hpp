#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>
#include <Eigen/Geometry>

#include <mutex>
#include <optional>
#include <string>

namespace mac_registration {

// The map -> odom output of a REP-105 localizer. A registration yields one correction; tf consumers ask
// for map -> base_link at "now", so the latest verified correction is re-sent at a steady rate until the
// next one, each time post-dated by a tolerance (as amcl does) so that lookups at the current time
// succeed between two sends.
class MapOdomBroadcaster {
 public:
  // rate_hz > 0 [Hz], tolerance >= 0 [s]; the timer runs on nh's callback queue.
  MapOdomBroadcaster(ros::NodeHandle nh, double rate_hz, double tolerance);

  // Replaces the correction and sends it at once.
  void setCorrection(const std::string& map_frame, const std::string& odom_frame,
                     const Eigen::Isometry3d& T_map_odom);
  bool hasCorrection() const;

 private:
  void sendLocked();

  mutable std::mutex mutex_;
  std::optional<geometry_msgs::TransformStamped> correction_;
  ros::Time last_stamp_;
  ros::Duration tolerance_;
  tf2_ros::TransformBroadcaster broadcaster_;
  ros::Timer timer_;
};

}  // namespace mac_registration
