#pragma once

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <mac_registration/Relocalize.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "mac_registration/config/parameter_table.hpp"
#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/map_relocalization.hpp"
#include "mac_registration/ros/map_odom_broadcaster.hpp"

namespace mac_registration {

// The relocalization node: a map loaded from ~map_file and described once (on its own thread, so that
// the node answers while it loads), and a ~relocalize service that localizes a cloud (or the latest scan on
// `source`) in it. A verified pose is published on ~pose (geometry_msgs/PoseWithCovarianceStamped) and, with
// ~publish_tf, as map -> odom (REP-105) through the odometry odom -> the scan's frame at its stamp.
// ~map_cloud carries the map's keypoints, latched, for rviz.
class RelocalizationServer {
 public:
  // The node's own parameters.
  struct Params {
    std::string map_file;              // PCD, PLY or KITTI .bin [m], z up
    std::string map_frame = "map";     // the frame of the map file's coordinates
    std::string odom_frame = "odom";   // publish_tf: the frame whose parent becomes map_frame
    bool publish_tf = true;            // send map -> odom for a verified pose
    double tf_timeout = 0.1;           // [s] waiting for odom <- the scan's frame at its stamp
    double map_odom_rate = 20.0;       // [Hz] re-send rate of the latest map -> odom
    double transform_tolerance = 0.1;  // [s] post-dating of each send
  };

  // Throws std::invalid_argument listing every invalid parameter (the algorithm's and the node's).
  RelocalizationServer(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~RelocalizationServer();
  RelocalizationServer(const RelocalizationServer&) = delete;
  RelocalizationServer& operator=(const RelocalizationServer&) = delete;

 private:
  void loadMap();
  void onSource(const sensor_msgs::PointCloud2ConstPtr& scan);
  bool onRelocalize(Relocalize::Request& request, Relocalize::Response& response);
  // The verified pose on ~pose and, with publish_tf, map -> odom; the reason in `response` when tf is not.
  void publishPose(const std_msgs::Header& query_header, const RelocalizationResult& result,
                   Relocalize::Response& response);

  ros::NodeHandle nh_, private_nh_;
  Params params_;
  RegistrationConfig config_;

  std::mutex map_mutex_;
  std::shared_ptr<const DescribedMap> map_;  // null until loaded
  std::string map_problem_;                  // why there is no map, once loading failed

  std::mutex scan_mutex_;
  sensor_msgs::PointCloud2ConstPtr latest_scan_;

  ros::Subscriber source_sub_;
  ros::Publisher pose_pub_, map_cloud_pub_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<MapOdomBroadcaster> map_odom_;

  StopFlag stop_{false};
  std::thread loader_;

  // Declared last: stopped before anything the calls use goes.
  ros::CallbackQueue service_queue_;
  ros::ServiceServer relocalize_srv_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
};

}  // namespace mac_registration
