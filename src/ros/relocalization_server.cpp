#include "mac_registration/ros/relocalization_server.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/ros/conversions.hpp"
#include "mac_registration/ros/server_config.hpp"

namespace mac_registration {

namespace {

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) text += "\n  " + line;
  return text;
}

// A typed private parameter: a value of another type is a problem, not a silent default.
template <typename T>
void readParam(const ros::NodeHandle& nh, const std::string& key, T& value,
               std::vector<std::string>& problems) {
  if (!nh.hasParam(key)) return;
  if (!nh.getParam(key, value)) problems.push_back("~" + key + ": wrong type");
}

RelocalizationServer::Params loadParams(const ros::NodeHandle& nh, std::vector<std::string>& problems) {
  RelocalizationServer::Params p;
  readParam(nh, "map_file", p.map_file, problems);
  readParam(nh, "map_frame", p.map_frame, problems);
  readParam(nh, "odom_frame", p.odom_frame, problems);
  readParam(nh, "publish_tf", p.publish_tf, problems);
  readParam(nh, "tf_timeout", p.tf_timeout, problems);
  readParam(nh, "map_odom_rate", p.map_odom_rate, problems);
  readParam(nh, "transform_tolerance", p.transform_tolerance, problems);
  if (p.map_file.empty()) problems.push_back("~map_file: not set (a PCD, PLY or .bin map cloud)");
  if (p.map_frame.empty()) problems.push_back("~map_frame: empty");
  if (p.publish_tf && (p.odom_frame.empty() || p.odom_frame == p.map_frame))
    problems.push_back("~odom_frame: must be set and differ from ~map_frame when ~publish_tf is true");
  if (!(p.tf_timeout >= 0.0)) problems.push_back("~tf_timeout: must be >= 0 [s]");
  if (!(p.map_odom_rate > 0.0 && p.map_odom_rate <= 1000.0))
    problems.push_back("~map_odom_rate: must be in (0, 1000] [Hz]");
  if (!(p.transform_tolerance >= 0.0 && p.transform_tolerance <= 10.0))
    problems.push_back("~transform_tolerance: must be in [0, 10] [s]");
  return p;
}

// The fit's covariance of a motion d = (x y z, rot x y z) of the query's own frame (T * exp(d)) as ROS's
// PoseWithCovariance holds it: the position's and the fixed-axis orientation's errors in the map frame,
// which to first order are R * d (blockwise).
std::array<double, 36> mapFrameCovariance(const Eigen::Isometry3d& T, const Eigen::Matrix<double, 6, 6>& c) {
  Eigen::Matrix<double, 6, 6> rotate = Eigen::Matrix<double, 6, 6>::Zero();
  rotate.topLeftCorner<3, 3>() = rotate.bottomRightCorner<3, 3>() = T.rotation();
  const Eigen::Matrix<double, 6, 6> in_map = rotate * c * rotate.transpose();
  std::array<double, 36> out{};
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) out[std::size_t(6 * r + k)] = in_map(r, k);
  }
  return out;
}

}  // namespace

RelocalizationServer::RelocalizationServer(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh), private_nh_(private_nh), tf_listener_(tf_buffer_) {
  std::vector<std::string> problems = loadRegistrationConfig(private_nh_, config_);
  params_ = loadParams(private_nh_, problems);
  if (config_.features.voxel_size <= 0.0)
    problems.push_back("~features/voxel_size: a map is described with a given voxel size, not auto (0)");
  if (!problems.empty()) throw std::invalid_argument("invalid parameters:" + joined(problems));
  ROS_INFO_STREAM("mac_relocalization: parameters:\n" << describeConfig(config_));

  pose_pub_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 1);
  map_cloud_pub_ = private_nh_.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, /*latch=*/true);
  if (params_.publish_tf)
    map_odom_ = std::make_unique<MapOdomBroadcaster>(nh_, params_.map_odom_rate, params_.transform_tolerance);
  source_sub_ = nh_.subscribe("source", 1, &RelocalizationServer::onSource, this);
  loader_ = std::thread([this] { loadMap(); });

  ros::AdvertiseServiceOptions options = ros::AdvertiseServiceOptions::create<Relocalize>(
      "relocalize",
      [this](Relocalize::Request& request, Relocalize::Response& response) {
        return onRelocalize(request, response);
      },
      ros::VoidConstPtr(), &service_queue_);
  relocalize_srv_ = private_nh_.advertiseService(options);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();
}

RelocalizationServer::~RelocalizationServer() {
  stop_ = true;
  if (service_spinner_) service_spinner_->stop();
  relocalize_srv_.shutdown();
  if (loader_.joinable()) loader_.join();
}

void RelocalizationServer::loadMap() {
  const auto start = std::chrono::steady_clock::now();
  ROS_INFO_STREAM("mac_relocalization: loading the map " << params_.map_file);
  try {
    std::vector<std::string> warnings;
    const PointCloud::Ptr cloud = loadCloud(params_.map_file, &warnings);
    for (const auto& w : warnings) ROS_WARN_STREAM("mac_relocalization: " << params_.map_file << ": " << w);
    ROS_INFO_STREAM("mac_relocalization: " << cloud->size() << " map points read; describing them");
    auto described = std::make_shared<const DescribedMap>(
        describeMap(*cloud, config_.features, config_.relocalization, &stop_));
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ROS_INFO_STREAM("mac_relocalization: map ready in "
                    << seconds << " s: " << described->cloud.keypoints->size() << " keypoints, "
                    << described->columns << " x " << described->rows << " places of " << described->cell_size
                    << " m, ~" << described->bytes() / (1 << 20) << " MiB");
    std_msgs::Header header;
    header.frame_id = params_.map_frame;
    header.stamp = ros::Time::now();
    map_cloud_pub_.publish(toPointCloud2(*described->cloud.keypoints,
                                         Eigen::Isometry3d(Eigen::Translation3d(described->origin)), header));
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_ = std::move(described);
  } catch (const Cancelled&) {
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_problem_ = "the node is shutting down";
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("mac_relocalization: no map: " << e.what());
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_problem_ = e.what();
  }
}

void RelocalizationServer::onSource(const sensor_msgs::PointCloud2ConstPtr& scan) {
  std::lock_guard<std::mutex> lock(scan_mutex_);
  latest_scan_ = scan;
}

bool RelocalizationServer::onRelocalize(Relocalize::Request& request, Relocalize::Response& response) {
  const auto refuse = [&](const std::string& outcome, const std::string& message) {
    response.success = false;
    response.outcome = outcome;
    response.message = message;
    ROS_WARN_STREAM("mac_relocalization: " << outcome << ": " << message);
    return true;
  };
  std::shared_ptr<const DescribedMap> map;
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    map = map_;
    if (!map)
      return refuse("no map", map_problem_.empty() ? "the map is still being described" : map_problem_);
  }
  sensor_msgs::PointCloud2ConstPtr query;
  if (request.cloud.width * request.cloud.height > 0) {
    query = boost::make_shared<const sensor_msgs::PointCloud2>(request.cloud);
  } else {
    std::lock_guard<std::mutex> lock(scan_mutex_);
    query = latest_scan_;
    if (!query)
      return refuse("invalid input",
                    "the request's cloud is empty and no scan has arrived on " + source_sub_.getTopic());
  }
  const CloudConversion converted = toPointCloud(*query);
  if (!converted.error.empty()) return refuse("invalid input", "query cloud: " + converted.error);
  RelocalizationParams params = config_.relocalization;
  if (request.max_candidates > 0) params.max_candidates = request.max_candidates;

  const RelocalizationResult result =
      relocalize(*map, *converted.cloud, config_.features, config_.mac, params, &stop_);
  response.success = result.success;
  response.outcome = toString(result.outcome);
  response.message = result.message;
  response.confidence = result.confidence;
  response.time_ms = result.total_ms;
  for (const PlaceCandidate& c : result.candidates) {
    mac_registration::RelocalizationCandidate msg;
    msg.centre.x = c.centre.x();
    msg.centre.y = c.centre.y();
    msg.centre.z = c.centre.z();
    msg.score = c.score;
    msg.votes = static_cast<std::uint32_t>(c.votes);
    msg.keypoints = static_cast<std::uint32_t>(c.keypoints);
    msg.registered = c.registered;
    if (c.registered) {
      const MacResult& r = c.registration.registration;
      msg.verified = r.success && c.unconstrained.empty();
      msg.pose = toPoseMsg(c.T_map_query);
      msg.confidence = r.confidence;
      msg.inliers = static_cast<std::uint32_t>(r.counters.inliers);
      msg.message = r.success ? c.unconstrained : r.message;
    }
    response.candidates.push_back(msg);
  }
  std::ostringstream log;
  log << "mac_relocalization: " << response.outcome << " in " << result.total_ms << " ms ("
      << result.candidates.size() << " places ranked)";
  if (result.success) {
    const Eigen::Vector3d t = result.T_map_query.translation();
    log << " at (" << t.x() << ", " << t.y() << ", " << t.z() << ") m, confidence " << result.confidence;
    publishPose(query->header, result, response);
  } else {
    log << ": " << result.message;
  }
  ROS_INFO_STREAM(log.str());
  return true;
}

void RelocalizationServer::publishPose(const std_msgs::Header& query_header,
                                       const RelocalizationResult& result, Relocalize::Response& response) {
  const MacResult& chosen = result.candidates[std::size_t(result.chosen)].registration.registration;
  geometry_msgs::PoseWithCovarianceStamped& pose = response.pose;
  pose.header.frame_id = params_.map_frame;
  pose.header.stamp = query_header.stamp.isZero() ? ros::Time::now() : query_header.stamp;
  pose.pose.pose = toPoseMsg(result.T_map_query);
  const auto covariance = mapFrameCovariance(result.T_map_query, chosen.fine_alignment.covariance);
  std::copy(covariance.begin(), covariance.end(), pose.pose.covariance.begin());
  pose_pub_.publish(pose);
  if (!map_odom_) return;
  if (query_header.frame_id.empty()) {
    response.message = "map -> odom not published: the query's frame_id is empty";
    ROS_WARN_STREAM("mac_relocalization: " << response.message);
    return;
  }
  try {
    const geometry_msgs::TransformStamped odom_query = tf_buffer_.lookupTransform(
        params_.odom_frame, query_header.frame_id, query_header.stamp, ros::Duration(params_.tf_timeout));
    const Eigen::Isometry3d T_map_odom = result.T_map_query * tf2::transformToEigen(odom_query).inverse();
    map_odom_->setCorrection(params_.map_frame, params_.odom_frame, T_map_odom);
  } catch (const tf2::TransformException& e) {
    response.message = "map -> odom not published: no transform " + params_.odom_frame + " <- " +
                       query_header.frame_id + " at the query's stamp (" + e.what() + ")";
    ROS_WARN_STREAM("mac_relocalization: " << response.message);
  }
}

}  // namespace mac_registration
