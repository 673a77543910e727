#include "mac_registration/ros/map_odom_broadcaster.hpp"

#include "mac_registration/ros/conversions.hpp"

namespace mac_registration {

MapOdomBroadcaster::MapOdomBroadcaster(ros::NodeHandle nh, double rate_hz, double tolerance)
    : tolerance_(tolerance) {
  timer_ = nh.createTimer(ros::Duration(1.0 / rate_hz), [this](const ros::TimerEvent&) {
    std::lock_guard<std::mutex> lock(mutex_);
    sendLocked();
  });
}

void MapOdomBroadcaster::setCorrection(const std::string& map_frame, const std::string& odom_frame,
                                       const Eigen::Isometry3d& T_map_odom) {
  geometry_msgs::TransformStamped tf;
  tf.header.frame_id = map_frame;
  tf.child_frame_id = odom_frame;
  tf.transform = toTransformMsg(T_map_odom);
  std::lock_guard<std::mutex> lock(mutex_);
  correction_ = tf;
  sendLocked();
}

bool MapOdomBroadcaster::hasCorrection() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return correction_.has_value();
}

void MapOdomBroadcaster::sendLocked() {
  const ros::Time now = ros::Time::now();
  // Simulated time before the first /clock message: nothing meaningful to stamp with.
  if (!correction_ || now.isZero()) return;
  const ros::Time stamp = now + tolerance_;
  // tf2 refuses (and every listener warns about) a second transform with the same stamp.
  if (stamp == last_stamp_) return;
  correction_->header.stamp = stamp;
  broadcaster_.sendTransform(*correction_);
  last_stamp_ = stamp;
}

}  // namespace mac_registration
