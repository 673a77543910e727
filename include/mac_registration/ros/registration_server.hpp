#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <mac_registration/Correspondences.h>
#include <mac_registration/MacRegistrationConfig.h>
#include <mac_registration/Register.h>
#include <mac_registration/RegisterCandidates.h>
#include <mac_registration/RegisterCorrespondences.h>
#include <mac_registration/RegistrationResult.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <boost/thread/recursive_mutex.hpp>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/ros/latest_slot.hpp"
#include "mac_registration/ros/map_odom_broadcaster.hpp"
#include "mac_registration/ros/server_config.hpp"

namespace mac_registration {

// Everything ROS of the package: inputs (source/target clouds, correspondences, two services), one worker
// with a latest-only slot, outputs (~result, ~aligned, ~correspondence_markers, tf, /diagnostics),
// parameters and dynamic_reconfigure. The nodelet and the node are thin shells around it.
//
// Threads: topic callbacks, timers and dynamic_reconfigure run on nh's queue and only hand work over; the
// worker registers topic inputs; the services have their own queue and spinner (~service_threads), so a
// long call neither delays the topics nor waits for another call. Every registration reads one StopFlag,
// raised by the destructor and when roscpp shuts down, so that none outlives the server.
class RegistrationServer {
 public:
  // Throws std::invalid_argument listing every invalid parameter.
  RegistrationServer(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~RegistrationServer();
  RegistrationServer(const RegistrationServer&) = delete;
  RegistrationServer& operator=(const RegistrationServer&) = delete;

 private:
  struct Job {
    sensor_msgs::PointCloud2ConstPtr source, target;
    mac_registration::CorrespondencesConstPtr correspondences;
    ros::Time received;  // stands in for a zero header.stamp
  };
  // Where the time of one registration went: what /diagnostics averages over the latest results.
  struct Timing {
    // The registration's stages from clouds in: the source's description, the matching and the core. A
    // target described for it is timed in target_description_ms instead.
    StageTimes stages;
    double conversion_ms = 0.0;          // PointCloud2 -> finite PCL cloud (the source)
    double target_description_ms = 0.0;  // conversion and description of the target; 0 when cached
    double publication_ms = 0.0;         // ~result, tf, and ~aligned / markers when subscribed
    double latency_ms = 0.0;  // the input's stamp (its arrival when zero) to the end of publication
  };
  // A registration with what the visual outputs need.
  struct Outcome {
    mac_registration::RegistrationResult msg;
    PointCloud::Ptr source_cloud;
    CorrespondenceSet correspondences;
    std::vector<int> inliers;
    Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
    // When to look the odometry up (map_odom mode): the input's stamp; zero means the latest.
    ros::Time odometry_stamp;
    Timing timing;
  };
  using SyncPolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::PointCloud2, sensor_msgs::PointCloud2>;

  void onSource(const sensor_msgs::PointCloud2ConstPtr& source);
  void onTarget(const sensor_msgs::PointCloud2ConstPtr& target);
  void onSynchronized(const sensor_msgs::PointCloud2ConstPtr& source,
                      const sensor_msgs::PointCloud2ConstPtr& target);
  void onCorrespondences(const mac_registration::CorrespondencesConstPtr& correspondences);
  bool onRegister(Register::Request& request, Register::Response& response);
  bool onRegisterCorrespondences(RegisterCorrespondences::Request& request,
                                 RegisterCorrespondences::Response& response);
  bool onRegisterCandidates(RegisterCandidates::Request& request, RegisterCandidates::Response& response);
  void onReconfigure(MacRegistrationConfig& config, std::uint32_t level);

  void workerLoop();
  // `cache_target`: the target came from the `target` topic (or a synchronized pair), so later sources
  // will likely meet it again; a service request's own target is described for that call alone.
  Outcome registerClouds(const sensor_msgs::PointCloud2& source,
                         const sensor_msgs::PointCloud2ConstPtr& target, const ros::Time& received,
                         bool cache_target);
  // The target's keypoints and descriptors, computed once per target message and feature parameters (a
  // latched map or keyframe is described once, not for every scan). Throws std::invalid_argument for an
  // unusable target.
  std::shared_ptr<const DescribedCloud> describedTarget(const sensor_msgs::PointCloud2ConstPtr& target,
                                                        const FeatureParams& params, std::size_t& dropped,
                                                        bool cache);
  std::shared_ptr<const DescribedCloud> describeTarget(const sensor_msgs::PointCloud2& target,
                                                       const FeatureParams& params, std::size_t& dropped);
  Outcome registerCorrespondences(const mac_registration::Correspondences& correspondences,
                                  const ros::Time& received);
  // One source against each target, described once (~register_candidates); in the targets' order.
  std::vector<Outcome> registerCandidateClouds(const sensor_msgs::PointCloud2& source,
                                               const std::vector<sensor_msgs::PointCloud2>& targets,
                                               const ros::Time& received);
  Outcome missingTarget(const sensor_msgs::PointCloud2& source, const std::string& why,
                        const ros::Time& received);
  // The result's stamp is the input's, or `received` when the input's is zero (said in a warning).
  void stampResult(const ros::Time& input_stamp, const ros::Time& received, Outcome& outcome);
  void publish(Outcome& outcome);
  // Sends the result on tf; in map_odom mode a missing odometry turns the outcome into a failure.
  void publishTf(Outcome& outcome, const NodeParams& node);
  void watchForShutdown();
  void reportDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  void recordTiming(const Timing& timing);
  static void reportRecentTimes(const std::deque<Timing>& recent,
                                diagnostic_updater::DiagnosticStatusWrapper& status);
  ServerConfig config() const;

  ros::NodeHandle nh_, private_nh_;
  mutable std::mutex config_mutex_;
  ServerConfig config_;

  ros::Subscriber source_sub_, target_sub_, correspondences_sub_;
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::PointCloud2>> sync_source_sub_, sync_target_sub_;
  std::unique_ptr<message_filters::Synchronizer<SyncPolicy>> synchronizer_;
  ros::Publisher result_pub_, aligned_pub_, markers_pub_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::unique_ptr<MapOdomBroadcaster> map_odom_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;
  std::unique_ptr<dynamic_reconfigure::Server<MacRegistrationConfig>> reconfigure_;
  boost::recursive_mutex reconfigure_mutex_;

  std::mutex target_mutex_;
  sensor_msgs::PointCloud2ConstPtr latest_target_;

  struct TargetCache {
    sensor_msgs::PointCloud2ConstPtr message;
    std::shared_ptr<const DescribedCloud> described;
    std::size_t dropped = 0;
  };
  // Held while the cached target is checked and described: a service call and the worker that meet the
  // same new target describe it once between them.
  std::mutex target_cache_mutex_;
  TargetCache target_cache_;

  std::mutex stats_mutex_;
  std::size_t registrations_ = 0, failures_ = 0;
  std::size_t unverified_ = 0;           // of the failures, transforms the verification did not confirm
  std::size_t inputs_received_ = 0;      // on the topics (sources, synchronized pairs, correspondences)
  std::size_t target_descriptions_ = 0;  // times a target cloud was described
  double last_target_description_ms_ = 0.0;
  std::deque<Timing> recent_times_;  // of the latest topic registrations, newest last
  mac_registration::RegistrationResult last_result_;

  StopFlag stop_{false};
  LatestSlot<Job> jobs_;
  std::thread worker_;

  // Declared after everything the calls use, so that they are stopped before any of it goes.
  ros::CallbackQueue service_queue_;
  ros::ServiceServer register_srv_, register_correspondences_srv_, register_candidates_srv_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;

  std::mutex shutdown_mutex_;
  std::condition_variable shutdown_cv_;
  bool destroying_ = false;
  std::thread shutdown_watch_;
};

}  // namespace mac_registration
