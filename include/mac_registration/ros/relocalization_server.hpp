#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <mac_registration/RelocalizationAnswer.h>
#include <mac_registration/Relocalize.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "mac_registration/config/parameter_table.hpp"
#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/map_relocalization.hpp"
#include "mac_registration/features/query_window.hpp"
#include "mac_registration/ros/map_odom_broadcaster.hpp"

namespace mac_registration {

// The relocalization node: a map (~map_file, or the latched `map` topic) described once on its own thread,
// so that the node answers while it loads; a query gathered from `source` (a window of keyframes joined by
// the odometry odom -> the scan's frame, or the latest scan); and a relocalization on the ~relocalize
// service, on a prior arriving on `initialpose`, and with ~relocalize_on_start until the first verified
// pose. A verified pose goes to ~pose (and `initialpose` with ~publish_initialpose), ~result, and with
// ~publish_tf to tf as map -> odom (REP-105). ~map_cloud carries the map's keypoints, latched, for rviz;
// /diagnostics the map's state and the latest answer. Relocalizations run one at a time on their own
// thread.
class RelocalizationServer {
 public:
  // The node's own parameters.
  struct Params {
    std::string map_file;              // PCD, PLY or KITTI .bin [m], z up; empty: the `map` topic
    std::string map_frame = "map";     // the frame of the map's coordinates
    std::string odom_frame = "odom";   // the odometry frame: the window's and map -> odom's
    bool publish_tf = true;            // send map -> odom for a verified pose
    double query_window = 16.0;        // [m] of travel joined into the query (0: the latest scan alone)
    double query_window_time = 60.0;   // [s] keyframes older than this leave the window
    bool relocalize_on_start = false;  // relocalize each new query until the first verified pose
    double prior_radius = 30.0;        // [m] the search radius around a prior without its own
    bool publish_initialpose = false;  // a verified pose also goes to `initialpose`
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
  // A cloud to localize with what publishing its pose needs.
  struct Query {
    PointCloud::Ptr cloud;
    std_msgs::Header header;                  // the cloud's frame and stamp
    std::optional<Eigen::Isometry3d> T_odom;  // the frame's odometry pose, when the window knows it
    std::string description;                  // for the result and the log
  };

  void describe(const PointCloud::Ptr& cloud, const Eigen::Vector3d& origin, const std::string& source);
  void onMapFile();
  void onMapTopic(const sensor_msgs::PointCloud2ConstPtr& map);
  void onSource(const sensor_msgs::PointCloud2ConstPtr& scan);
  void addToWindow(const sensor_msgs::PointCloud2& scan);
  bool onRelocalize(Relocalize::Request& request, Relocalize::Response& response);
  void onInitialPose(const ros::MessageEvent<const geometry_msgs::PoseWithCovarianceStamped>& event);
  void onStartTimer();

  // The node's own query (the window, or the latest scan); nullopt with the reason when there is none.
  std::optional<Query> currentQuery(std::string& why);
  // Localizes, publishes a verified pose and ~result, and logs; the answer.
  RelocalizationResult run(const Query& query, const SearchArea* area, unsigned max_candidates,
                           const std::string& trigger, mac_registration::RelocalizationAnswer& msg);
  void publishPose(const Query& query, const RelocalizationResult& result,
                   mac_registration::RelocalizationAnswer& msg);
  void reportDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  void logMapProgress();

  ros::NodeHandle nh_, private_nh_;
  Params params_;
  RegistrationConfig config_;

  std::mutex map_mutex_;
  std::shared_ptr<const DescribedMap> map_;  // null until described
  std::string map_state_;                    // what the map is doing: loading, its source, why it failed
  std::size_t map_points_ = 0;
  double map_seconds_ = 0.0;
  // While a map is being described: when it started and the points it holds (the progress log).
  bool describing_ = false;
  std::chrono::steady_clock::time_point describe_start_;
  std::size_t describing_points_ = 0;
  sensor_msgs::PointCloud2ConstPtr map_msg_;  // the last map taken from the topic

  std::mutex query_mutex_;
  sensor_msgs::PointCloud2ConstPtr latest_scan_;
  QueryWindow window_{QueryWindowParams{}};
  std::string window_frame_;
  std::uint64_t query_version_ = 0;  // counts the queries the node has gathered
  std::uint64_t tried_version_ = 0;  // the one ~relocalize_on_start tried last

  std::mutex stats_mutex_;
  std::size_t relocalizations_ = 0, localized_ = 0;
  mac_registration::RelocalizationAnswer last_;
  bool verified_once_ = false;

  ros::Subscriber source_sub_, map_sub_, initialpose_sub_;
  ros::Publisher pose_pub_, result_pub_, map_cloud_pub_, initialpose_pub_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<MapOdomBroadcaster> map_odom_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;
  ros::WallTimer progress_timer_;  // logs a long map description's progress

  StopFlag stop_{false};      // the node is shutting down
  StopFlag map_stop_{false};  // a newer map replaces the one being described
  std::thread describer_;

  // Declared last: stopped before anything the relocalizations use goes.
  ros::CallbackQueue relocalization_queue_;
  ros::ServiceServer relocalize_srv_;
  ros::WallTimer start_timer_;
  std::unique_ptr<ros::AsyncSpinner> relocalization_spinner_;
};

}  // namespace mac_registration
