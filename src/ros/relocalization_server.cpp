#include "mac_registration/ros/relocalization_server.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/ros/conversions.hpp"
#include "mac_registration/ros/server_config.hpp"

namespace mac_registration {

namespace {

const char* const kLog = "mac_relocalization: ";

// The process's peak resident memory [MiB] (VmHWM), 0 where /proc does not tell.
std::size_t peakResidentMiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    // kB in the file; strtoul, unlike stoul, cannot throw inside a timer callback of the manager.
    if (line.rfind("VmHWM:", 0) == 0) return std::strtoul(line.c_str() + 6, nullptr, 10) >> 10;
  }
  return 0;
}

// Seconds between two progress lines of a map description.
constexpr double kProgressPeriod = 10.0;

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
  readParam(nh, "query_window", p.query_window, problems);
  readParam(nh, "query_window_time", p.query_window_time, problems);
  readParam(nh, "relocalize_on_start", p.relocalize_on_start, problems);
  readParam(nh, "prior_radius", p.prior_radius, problems);
  readParam(nh, "publish_initialpose", p.publish_initialpose, problems);
  readParam(nh, "tf_timeout", p.tf_timeout, problems);
  readParam(nh, "map_odom_rate", p.map_odom_rate, problems);
  readParam(nh, "transform_tolerance", p.transform_tolerance, problems);
  if (p.map_frame.empty()) problems.push_back("~map_frame: empty");
  if ((p.publish_tf || p.query_window > 0.0) && (p.odom_frame.empty() || p.odom_frame == p.map_frame))
    problems.push_back(
        "~odom_frame: must be set and differ from ~map_frame when ~publish_tf is true or ~query_window > 0");
  if (!(p.query_window >= 0.0 && p.query_window <= 1000.0))
    problems.push_back("~query_window: must be in [0, 1000] [m] (0: the latest scan alone)");
  if (!(p.query_window_time > 0.0)) problems.push_back("~query_window_time: must be > 0 [s]");
  if (!(p.prior_radius > 0.0)) problems.push_back("~prior_radius: must be > 0 [m]");
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

mac_registration::RelocalizationCandidate candidateMsg(const PlaceCandidate& c) {
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
  return msg;
}

}  // namespace

RelocalizationServer::RelocalizationServer(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh), private_nh_(private_nh), tf_listener_(tf_buffer_), diagnostics_(nh, private_nh) {
  std::vector<std::string> problems = loadRegistrationConfig(private_nh_, config_);
  params_ = loadParams(private_nh_, problems);
  if (config_.features.voxel_size <= 0.0)
    problems.push_back("~features/voxel_size: a map is described with a given voxel size, not auto (0)");
  if (!problems.empty()) throw std::invalid_argument("invalid parameters:" + joined(problems));
  window_ = QueryWindow({params_.query_window, params_.query_window_time, config_.features.voxel_size});
  ROS_INFO_STREAM(kLog << "parameters:\n" << describeConfig(config_));

  pose_pub_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 1);
  result_pub_ = private_nh_.advertise<mac_registration::RelocalizationAnswer>("result", 5);
  map_cloud_pub_ = private_nh_.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, /*latch=*/true);
  if (params_.publish_initialpose)
    initialpose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("initialpose", 1);
  if (params_.publish_tf)
    map_odom_ = std::make_unique<MapOdomBroadcaster>(nh_, params_.map_odom_rate, params_.transform_tolerance);
  diagnostics_.setHardwareID("mac_registration");
  diagnostics_.add("relocalization", this, &RelocalizationServer::reportDiagnostics);
  diagnostics_timer_ =
      nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { diagnostics_.update(); });
  progress_timer_ = nh_.createWallTimer(ros::WallDuration(kProgressPeriod),
                                        [this](const ros::WallTimerEvent&) { logMapProgress(); });

  source_sub_ = nh_.subscribe("source", 5, &RelocalizationServer::onSource, this);
  if (!params_.map_file.empty()) {
    map_state_ = "loading " + params_.map_file;
    describer_ = std::thread([this] { onMapFile(); });
  } else {
    map_sub_ = nh_.subscribe("map", 1, &RelocalizationServer::onMapTopic, this);
    map_state_ = "waiting for a map on " + map_sub_.getTopic();
    ROS_INFO_STREAM(kLog << "~map_file is not set: " << map_state_);
  }

  // The relocalizations, whatever calls them, run one at a time on their own thread.
  ros::AdvertiseServiceOptions service = ros::AdvertiseServiceOptions::create<Relocalize>(
      "relocalize",
      [this](Relocalize::Request& request, Relocalize::Response& response) {
        return onRelocalize(request, response);
      },
      ros::VoidConstPtr(), &relocalization_queue_);
  relocalize_srv_ = private_nh_.advertiseService(service);
  ros::SubscribeOptions prior;
  prior.initByFullCallbackType<const ros::MessageEvent<const geometry_msgs::PoseWithCovarianceStamped>&>(
      "initialpose", 1, [this](const auto& event) { onInitialPose(event); });
  prior.callback_queue = &relocalization_queue_;
  initialpose_sub_ = nh_.subscribe(prior);
  if (params_.relocalize_on_start) {
    // Wall time: with a replayed bag's clock stopped, the node still tries the query it holds.
    ros::WallTimerOptions start(
        ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { onStartTimer(); },
        &relocalization_queue_);
    start_timer_ = nh_.createWallTimer(start);
  }
  relocalization_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &relocalization_queue_);
  relocalization_spinner_->start();
}

RelocalizationServer::~RelocalizationServer() {
  stop_ = true;
  map_stop_ = true;
  map_sub_.shutdown();
  start_timer_.stop();
  progress_timer_.stop();
  if (relocalization_spinner_) relocalization_spinner_->stop();
  relocalize_srv_.shutdown();
  initialpose_sub_.shutdown();
  if (describer_.joinable()) describer_.join();
}

void RelocalizationServer::describe(const PointCloud::Ptr& cloud, const Eigen::Vector3d& origin,
                                    const std::string& source) {
  const auto start = std::chrono::steady_clock::now();
  ROS_INFO_STREAM(kLog << cloud->size() << " map points from " << source << "; describing them");
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_state_ = "describing " + source;
    describing_ = true;
    describe_start_ = start;
    describing_points_ = cloud->size();
  }
  try {
    DescribedMap described =
        describeMap(*cloud, config_.features, config_.relocalization, &map_stop_, origin);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ROS_INFO_STREAM(kLog << "map ready in " << seconds << " s: " << described.cloud.keypoints->size()
                         << " keypoints, " << described.columns << " x " << described.rows << " places of "
                         << described.cell_size << " m, ~" << described.bytes() / (1 << 20)
                         << " MiB (the process's peak: " << peakResidentMiB() << " MiB)");
    std_msgs::Header header;
    header.frame_id = params_.map_frame;
    header.stamp = ros::Time::now();
    map_cloud_pub_.publish(toPointCloud2(*described.cloud.keypoints,
                                         Eigen::Isometry3d(Eigen::Translation3d(described.origin)), header));
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_ = std::make_shared<const DescribedMap>(std::move(described));
    map_state_ = "ready: " + source;
    map_points_ = cloud->size();
    map_seconds_ = seconds;
    describing_ = false;
  } catch (const Cancelled&) {
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_state_ = stop_ ? "the node is shutting down" : "replaced by a newer map";
    describing_ = false;
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM(kLog << "cannot describe the map from " << source << ": " << e.what());
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_state_ = std::string("failed: ") + e.what() + (map_ ? " (the previous map stays in use)" : "");
    describing_ = false;
  }
}

void RelocalizationServer::logMapProgress() {
  std::lock_guard<std::mutex> lock(map_mutex_);
  if (!describing_) return;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - describe_start_).count();
  ROS_INFO_STREAM(kLog << "still describing the map (" << describing_points_
                       << " points): " << std::lround(seconds) << " s so far, " << peakResidentMiB()
                       << " MiB peak memory; queries wait for it");
}

void RelocalizationServer::onMapFile() {
  ROS_INFO_STREAM(kLog << "loading the map " << params_.map_file);
  try {
    std::vector<std::string> warnings;
    const LocalCloud map = loadLocalCloud(params_.map_file, &warnings);
    for (const auto& w : warnings) ROS_WARN_STREAM(kLog << w);
    if (!map.origin.isZero()) {
      ROS_INFO_STREAM(kLog << "the map's coordinates are global: described around (" << map.origin.transpose()
                           << ") m, every output in " << params_.map_frame << " as the file's");
    }
    describe(map.cloud, map.origin, params_.map_file);
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM(kLog << "no map: " << e.what());
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_state_ = std::string("failed: ") + e.what();
  }
}

void RelocalizationServer::onMapTopic(const sensor_msgs::PointCloud2ConstPtr& map) {
  const std::string source = "topic " + map_sub_.getTopic();
  if (!map->header.frame_id.empty() && map->header.frame_id != params_.map_frame) {
    ROS_ERROR_STREAM(kLog << "map on " << map_sub_.getTopic() << " ignored: its frame '"
                          << map->header.frame_id << "' is not ~map_frame '" << params_.map_frame << "'");
    return;
  }
  // A latched map arrives again when its publisher reconnects: the same map is not described twice.
  if (map_msg_ && map_msg_->header.stamp == map->header.stamp && map_msg_->data.size() == map->data.size() &&
      map_msg_->data == map->data)
    return;
  const CloudConversion converted = toPointCloud(*map);
  if (!converted.error.empty()) {
    ROS_ERROR_STREAM(kLog << "map on " << map_sub_.getTopic() << " ignored: " << converted.error);
    return;
  }
  map_stop_ = true;
  if (describer_.joinable()) describer_.join();
  map_stop_ = false;
  map_msg_ = map;
  describer_ = std::thread(
      [this, cloud = converted.cloud, source] { describe(cloud, Eigen::Vector3d::Zero(), source); });
}

void RelocalizationServer::onSource(const sensor_msgs::PointCloud2ConstPtr& scan) {
  {
    std::lock_guard<std::mutex> lock(query_mutex_);
    latest_scan_ = scan;
    if (params_.query_window <= 0.0) ++query_version_;
  }
  if (params_.query_window > 0.0) addToWindow(*scan);
}

void RelocalizationServer::addToWindow(const sensor_msgs::PointCloud2& scan) {
  const std::string& frame = scan.header.frame_id;
  if (frame.empty()) {
    ROS_WARN_STREAM_THROTTLE(10.0, kLog << "a scan on " << source_sub_.getTopic()
                                        << " has no frame_id: it cannot join the query window");
    return;
  }
  Eigen::Isometry3d T_odom_scan;
  try {
    T_odom_scan = tf2::transformToEigen(tf_buffer_.lookupTransform(
        params_.odom_frame, frame, scan.header.stamp, ros::Duration(params_.tf_timeout)));
  } catch (const tf2::TransformException& e) {
    ROS_WARN_STREAM_THROTTLE(10.0, kLog << "a scan cannot join the query window: no transform "
                                        << params_.odom_frame << " <- " << frame << " at its stamp ("
                                        << e.what() << ")");
    return;
  }
  bool wanted = false;
  {
    std::lock_guard<std::mutex> lock(query_mutex_);
    if (frame != window_frame_) {
      window_.clear();
      window_frame_ = frame;
    }
    wanted = window_.wantsScan(T_odom_scan);
  }
  CloudConversion converted;
  if (wanted) {
    converted = toPointCloud(scan);
    if (!converted.error.empty()) {
      ROS_WARN_STREAM_THROTTLE(10.0, kLog << "a scan cannot join the query window: " << converted.error);
      return;
    }
  }
  try {
    std::lock_guard<std::mutex> lock(query_mutex_);
    const std::size_t before = window_.keyframes();
    const Eigen::Isometry3d newest = window_.empty() ? Eigen::Isometry3d::Identity() : window_.newestPose();
    window_.add(wanted ? *converted.cloud : PointCloud(), T_odom_scan, scan.header.stamp.toSec());
    if (window_.keyframes() != before || !window_.newestPose().isApprox(newest)) ++query_version_;
  } catch (const std::exception& e) {
    ROS_WARN_STREAM_THROTTLE(10.0, kLog << "a scan cannot join the query window: " << e.what());
  }
}

std::optional<RelocalizationServer::Query> RelocalizationServer::currentQuery(std::string& why) {
  std::lock_guard<std::mutex> lock(query_mutex_);
  Query query;
  if (params_.query_window > 0.0 && !window_.empty()) {
    query.cloud = window_.assemble();
    query.header.frame_id = window_frame_;
    query.header.stamp.fromSec(window_.newestStamp());
    query.T_odom = window_.newestPose();
    std::ostringstream text;
    text << "a window of " << window_.keyframes() << (window_.keyframes() == 1 ? " keyframe" : " keyframes")
         << " over " << std::round(10.0 * window_.travel()) / 10.0 << " m from " << source_sub_.getTopic();
    query.description = text.str();
    return query;
  }
  if (!latest_scan_) {
    why = "no scan has arrived on " + source_sub_.getTopic();
    if (params_.query_window > 0.0) why += " that could be placed in " + params_.odom_frame;
    return std::nullopt;
  }
  const CloudConversion converted = toPointCloud(*latest_scan_);
  if (!converted.error.empty()) {
    why = "the latest scan on " + source_sub_.getTopic() + ": " + converted.error;
    return std::nullopt;
  }
  query.cloud = converted.cloud;
  query.header = latest_scan_->header;
  query.description = "the latest scan on " + source_sub_.getTopic();
  return query;
}

bool RelocalizationServer::onRelocalize(Relocalize::Request& request, Relocalize::Response& response) {
  mac_registration::RelocalizationAnswer& msg = response.result;
  msg.trigger = "service";
  std::optional<Query> query;
  std::string why;
  if (request.cloud.width * request.cloud.height > 0) {
    const CloudConversion converted = toPointCloud(request.cloud);
    if (converted.error.empty()) {
      query = Query{converted.cloud, request.cloud.header, std::nullopt, "the request's cloud"};
    } else {
      why = "the request's cloud: " + converted.error;
    }
  } else {
    query = currentQuery(why);
  }
  if (!query) {
    msg.outcome = "invalid input";
    msg.message = why;
    ROS_WARN_STREAM(kLog << msg.outcome << ": " << msg.message);
    return true;
  }
  SearchArea area;
  if (request.use_prior) {
    area.centre << request.prior.x, request.prior.y;
    area.radius = request.prior_radius > 0.0 ? request.prior_radius : params_.prior_radius;
  }
  run(*query, request.use_prior ? &area : nullptr, request.max_candidates, "service", msg);
  return true;
}

void RelocalizationServer::onInitialPose(
    const ros::MessageEvent<const geometry_msgs::PoseWithCovarianceStamped>& event) {
  if (event.getPublisherName() == ros::this_node::getName()) return;  // our own pose, for a tracker
  const geometry_msgs::PoseWithCovarianceStamped& prior = *event.getMessage();
  if (!prior.header.frame_id.empty() && prior.header.frame_id != params_.map_frame) {
    ROS_WARN_STREAM(kLog << "a prior on initialpose in frame '" << prior.header.frame_id
                         << "', not ~map_frame '" << params_.map_frame << "': ignored");
    return;
  }
  std::string why;
  const std::optional<Query> query = currentQuery(why);
  if (!query) {
    ROS_WARN_STREAM(kLog << "a prior on initialpose, but nothing to localize: " << why);
    return;
  }
  // rviz's pose estimate carries a position spread of 0.5 m: the radius is the larger of ~prior_radius and
  // three standard deviations of the prior.
  const auto& c = prior.pose.covariance;
  SearchArea area;
  area.centre << prior.pose.pose.position.x, prior.pose.pose.position.y;
  area.radius = std::max(params_.prior_radius, 3.0 * std::sqrt(std::max({c[0], c[7], 0.0})));
  mac_registration::RelocalizationAnswer msg;
  run(*query, &area, 0, "initialpose", msg);
}

void RelocalizationServer::onStartTimer() {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (verified_once_) {
      start_timer_.stop();
      return;
    }
  }
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    if (!map_) return;
  }
  {
    std::lock_guard<std::mutex> lock(query_mutex_);
    if (query_version_ == tried_version_) return;
    tried_version_ = query_version_;
  }
  std::string why;
  const std::optional<Query> query = currentQuery(why);
  if (!query) return;
  mac_registration::RelocalizationAnswer msg;
  run(*query, nullptr, 0, "start", msg);
}

RelocalizationResult RelocalizationServer::run(const Query& query, const SearchArea* area,
                                               unsigned max_candidates, const std::string& trigger,
                                               mac_registration::RelocalizationAnswer& msg) {
  msg.trigger = trigger;
  msg.query = query.description;
  std::shared_ptr<const DescribedMap> map;
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    map = map_;
    msg.message = map_state_;
  }
  RelocalizationResult result;
  if (!map) {
    msg.outcome = "no map";
    ROS_WARN_STREAM(kLog << "no map (" << trigger << "): " << msg.message);
  } else {
    RelocalizationParams params = config_.relocalization;
    if (max_candidates > 0) params.max_candidates = max_candidates;
    result = relocalize(*map, *query.cloud, config_.features, config_.mac, params, &stop_, area);
    msg.success = result.success;
    msg.outcome = toString(result.outcome);
    msg.message = result.message;
    msg.confidence = result.confidence;
    msg.time_ms = result.total_ms;
    for (const PlaceCandidate& c : result.candidates) msg.candidates.push_back(candidateMsg(c));
    if (result.success) publishPose(query, result, msg);
    std::ostringstream log;
    log << kLog << msg.outcome << " (" << trigger << ", " << query.description << ") in " << result.total_ms
        << " ms, " << result.candidates.size() << " places ranked"
        << (area ? " within " + std::to_string(int(std::round(area->radius))) + " m of the prior" : "");
    if (result.success) {
      const Eigen::Vector3d t = result.T_map_query.translation();
      log << ": at (" << t.x() << ", " << t.y() << ", " << t.z() << ") m, confidence " << result.confidence;
    }
    if (!msg.message.empty()) log << ": " << msg.message;
    ROS_INFO_STREAM(log.str());
  }
  result_pub_.publish(msg);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++relocalizations_;
  localized_ += msg.success;
  verified_once_ = verified_once_ || msg.success;
  last_ = msg;
  return result;
}

void RelocalizationServer::publishPose(const Query& query, const RelocalizationResult& result,
                                       mac_registration::RelocalizationAnswer& msg) {
  const MacResult& chosen = result.candidates[std::size_t(result.chosen)].registration.registration;
  geometry_msgs::PoseWithCovarianceStamped& pose = msg.pose;
  pose.header.frame_id = params_.map_frame;
  pose.header.stamp = query.header.stamp.isZero() ? ros::Time::now() : query.header.stamp;
  pose.pose.pose = toPoseMsg(result.T_map_query);
  const auto covariance = mapFrameCovariance(result.T_map_query, chosen.fine_alignment.covariance);
  std::copy(covariance.begin(), covariance.end(), pose.pose.covariance.begin());
  pose_pub_.publish(pose);
  if (params_.publish_initialpose) initialpose_pub_.publish(pose);
  if (!map_odom_) return;
  Eigen::Isometry3d T_odom_query;
  if (query.T_odom) {
    T_odom_query = *query.T_odom;
  } else if (query.header.frame_id.empty()) {
    msg.message = "map -> odom not published: the query's frame_id is empty";
    ROS_WARN_STREAM(kLog << msg.message);
    return;
  } else {
    try {
      T_odom_query = tf2::transformToEigen(tf_buffer_.lookupTransform(
          params_.odom_frame, query.header.frame_id, query.header.stamp, ros::Duration(params_.tf_timeout)));
    } catch (const tf2::TransformException& e) {
      msg.message = "map -> odom not published: no transform " + params_.odom_frame + " <- " +
                    query.header.frame_id + " at the query's stamp (" + e.what() + ")";
      ROS_WARN_STREAM(kLog << msg.message);
      return;
    }
  }
  map_odom_->setCorrection(params_.map_frame, params_.odom_frame,
                           result.T_map_query * T_odom_query.inverse());
}

void RelocalizationServer::reportDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    if (!map_ && map_state_.rfind("failed", 0) == 0) {
      status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "no map: " + map_state_);
    } else if (!map_) {
      status.summary(diagnostic_msgs::DiagnosticStatus::OK, map_state_);
    }
    status.add("map", map_state_);
    if (describing_) {
      status.addf("map description so far [s]", "%.0f",
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - describe_start_).count());
    }
    status.add("process peak memory [MiB]", peakResidentMiB());
    if (map_) {
      status.add("map points", map_points_);
      status.add("map keypoints", map_->cloud.keypoints->size());
      status.add("map places", map_->columns * map_->rows);
      status.addf("map description [s]", "%.3f", map_seconds_);
      status.add("map memory [MiB]", map_->bytes() >> 20);
    }
  }
  {
    std::lock_guard<std::mutex> lock(query_mutex_);
    status.add("window keyframes", window_.keyframes());
    status.addf("window travel [m]", "%.1f", window_.travel());
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  if (status.level == diagnostic_msgs::DiagnosticStatus::OK && status.message.empty()) {
    if (relocalizations_ == 0) {
      status.summary(diagnostic_msgs::DiagnosticStatus::OK, "map ready, no query yet");
    } else {
      status.summary(
          last_.success ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN,
          "last query: " + last_.outcome + (last_.message.empty() ? "" : ": " + last_.message));
    }
  }
  status.add("relocalizations", relocalizations_);
  status.add("localized", localized_);
  status.add("last outcome", last_.outcome);
  status.add("last query", last_.query);
  status.add("last trigger", last_.trigger);
  status.addf("last time [ms]", "%.0f", last_.time_ms);
}

}  // namespace mac_registration
