#include "mac_registration/ros/registration_server.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/ros/conversions.hpp"
#include "mac_registration/ros/reconfigure_mapping.hpp"
#include "mac_registration/ros/visualization.hpp"

namespace mac_registration {
namespace {

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) text += "\n  - " + line;
  return text;
}

mac_registration::RegistrationResult invalidInput(const std::string& message) {
  mac_registration::RegistrationResult msg;
  msg.success = false;
  msg.status = mac_registration::RegistrationResult::INVALID_INPUT;
  msg.message = message;
  msg.transform.rotation.w = 1.0;
  fillVerification(MacResult{}, msg);  // nothing verified: no estimate, NaN signals
  return msg;
}

// A registration the stop flag ended before the core ran (e.g. while the target was described).
mac_registration::RegistrationResult cancelled(const std::string& message) {
  MacResult result;
  result.status = RegistrationStatus::kCancelled;
  result.message = message;
  mac_registration::RegistrationResult msg;
  fillResultMsg(result, msg);
  return msg;
}

// A failure after the registration itself: the counters stay, the transform goes back to the identity.
void markFailed(mac_registration::RegistrationResult& msg, std::uint8_t status, const std::string& message) {
  msg.success = false;
  msg.status = status;
  msg.message = message;
  msg.transform = geometry_msgs::Transform();
  msg.transform.rotation.w = 1.0;
}

// `times` without those of describing `described` (a target, timed apart with its conversion; 0 once cached).
StageTimes withoutDescription(StageTimes times, const StageTimes& described) {
  times.resolution_ms -= described.resolution_ms;
  times.downsample_ms -= described.downsample_ms;
  times.normals_ms -= described.normals_ms;
  times.features_ms -= described.features_ms;
  times.total_ms -= described.total_ms;
  return times;
}

// Enough for a burst of inputs while the callback thread is busy elsewhere; beyond that roscpp would
// drop without a trace, whereas the slot counts what it replaces.
constexpr std::uint32_t kInputQueueSize = 5;

RegistrationConfig algorithmOf(const ServerConfig& config) {
  return {config.mac, config.features, config.relocalization};
}

bool sameReconfigurable(const ServerConfig& a, const ServerConfig& b) {
  for (const auto& key : reconfigurableKeys()) {
    const Parameter* p = findParameter(key);
    if (p->get(algorithmOf(a)) != p->get(algorithmOf(b))) return false;
  }
  return true;
}

// How many of the latest topic registrations /diagnostics averages its times over: 10 s of a 10 Hz lidar.
constexpr std::size_t kTimedResults = 100;

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The given quantile (nearest rank) of the values; 0 for none.
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const auto rank = std::min(values.size() - 1, static_cast<std::size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + rank, values.end());
  return values[rank];
}

// A cached description serves these parameters too: the descriptors depend only on the voxel size and
// radii (describedWith), but a resolution is estimated only when some parameter uses it.
bool describedFor(const DescribedCloud& cloud, const FeatureParams& params) {
  if (!describedWith(cloud, params)) return false;
  if (!resolutionNeeded(params)) return true;
  return resolutionNeeded(cloud.params) && cloud.params.resolution_samples == params.resolution_samples;
}

std::string stampText(const ros::Time& stamp) {
  std::ostringstream text;
  text << "t = " << stamp.sec << "." << std::setw(9) << std::setfill('0') << stamp.nsec << " s";
  return text.str();
}

}  // namespace

// The latency quantiles and the mean time of each stage over the latest topic registrations.
void RegistrationServer::reportRecentTimes(const std::deque<Timing>& recent,
                                           diagnostic_updater::DiagnosticStatusWrapper& status) {
  status.add("timed results", recent.size());
  std::vector<double> latency;
  Timing sum;
  for (const Timing& t : recent) {
    latency.push_back(t.latency_ms);
    sum.stages += t.stages;
    sum.conversion_ms += t.conversion_ms;
    sum.target_description_ms += t.target_description_ms;
    sum.publication_ms += t.publication_ms;
  }
  const StageTimes& s = sum.stages;
  const double n = std::max<std::size_t>(1, recent.size());
  status.addf("latency p50 [ms]", "%.1f", quantile(latency, 0.5));
  status.addf("latency p95 [ms]", "%.1f", quantile(latency, 0.95));
  status.addf("mean conversion [ms]", "%.1f", sum.conversion_ms / n);
  status.addf("mean target description [ms]", "%.1f", sum.target_description_ms / n);
  status.addf("mean source description [ms]", "%.1f", (s.frontEndMs() - s.matching_ms) / n);
  status.addf("mean matching [ms]", "%.1f", s.matching_ms / n);
  status.addf("mean core [ms]", "%.1f", (s.total_ms - s.frontEndMs() - s.verification_ms) / n);
  status.addf("mean verification [ms]", "%.1f", s.verification_ms / n);
  status.addf("mean publication [ms]", "%.1f", sum.publication_ms / n);
}

RegistrationServer::RegistrationServer(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh), private_nh_(private_nh), tf_listener_(tf_buffer_), diagnostics_(nh, private_nh) {
  const auto problems = loadServerConfig(private_nh_, config_);
  if (!problems.empty()) {
    throw std::invalid_argument("invalid parameters in " + private_nh_.getNamespace() + ":" +
                                joined(problems));
  }
  ROS_INFO_STREAM("mac_registration: effective configuration (" << private_nh_.getNamespace() << "):\n"
                                                                << describeConfig(config_));
  ROS_INFO_STREAM("mac_registration: SIMD kernels " << kernelsInUse());

  result_pub_ = private_nh_.advertise<mac_registration::RegistrationResult>("result", 10);
  aligned_pub_ = private_nh_.advertise<sensor_msgs::PointCloud2>("aligned", 1);
  markers_pub_ = private_nh_.advertise<visualization_msgs::MarkerArray>("correspondence_markers", 1);

  if (config_.node.target_mode == NodeParams::TargetMode::kSynchronized) {
    sync_source_sub_ = std::make_unique<message_filters::Subscriber<sensor_msgs::PointCloud2>>(
        nh_, "source", kInputQueueSize);
    sync_target_sub_ = std::make_unique<message_filters::Subscriber<sensor_msgs::PointCloud2>>(
        nh_, "target", kInputQueueSize);
    synchronizer_ = std::make_unique<message_filters::Synchronizer<SyncPolicy>>(
        SyncPolicy(5), *sync_source_sub_, *sync_target_sub_);
    synchronizer_->setMaxIntervalDuration(ros::Duration(config_.node.sync_slop));
    synchronizer_->registerCallback(&RegistrationServer::onSynchronized, this);
  } else {
    source_sub_ = nh_.subscribe("source", kInputQueueSize, &RegistrationServer::onSource, this);
    target_sub_ = nh_.subscribe("target", kInputQueueSize, &RegistrationServer::onTarget, this);
  }
  correspondences_sub_ =
      nh_.subscribe("correspondences", kInputQueueSize, &RegistrationServer::onCorrespondences, this);
  if (config_.node.publish_tf && config_.node.tf_mode == NodeParams::TfMode::kMapOdom) {
    map_odom_ = std::make_unique<MapOdomBroadcaster>(nh_, config_.node.map_odom_rate,
                                                     config_.node.transform_tolerance);
  }

  diagnostics_.setHardwareID("mac_registration");
  diagnostics_.add("registration", this, &RegistrationServer::reportDiagnostics);
  diagnostics_timer_ =
      nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { diagnostics_.update(); });

  // The reconfigure server starts from the loaded values, not from its own defaults.
  reconfigure_ =
      std::make_unique<dynamic_reconfigure::Server<MacRegistrationConfig>>(reconfigure_mutex_, private_nh_);
  MacRegistrationConfig initial = MacRegistrationConfig::__getDefault__();
  toReconfigure(algorithmOf(config_), initial);
  reconfigure_->updateConfig(initial);
  reconfigure_->setCallback(
      [this](MacRegistrationConfig& c, std::uint32_t level) { onReconfigure(c, level); });

  // The services on their own queue: a long call must not hold up the topics, the timers or another call.
  ros::NodeHandle service_nh(private_nh_);
  service_nh.setCallbackQueue(&service_queue_);
  register_srv_ = service_nh.advertiseService("register", &RegistrationServer::onRegister, this);
  register_correspondences_srv_ = service_nh.advertiseService(
      "register_correspondences", &RegistrationServer::onRegisterCorrespondences, this);
  register_candidates_srv_ =
      service_nh.advertiseService("register_candidates", &RegistrationServer::onRegisterCandidates, this);

  worker_ = std::thread([this] { workerLoop(); });
  shutdown_watch_ = std::thread([this] { watchForShutdown(); });
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(config_.node.service_threads, &service_queue_);
  service_spinner_->start();
  ROS_INFO_STREAM("mac_registration: listening on " << nh_.resolveName("source") << ", "
                                                    << nh_.resolveName("target") << " and "
                                                    << nh_.resolveName("correspondences"));
}

RegistrationServer::~RegistrationServer() {
  // Running registrations end at their next check of the flag, so that nothing below waits long.
  stop_ = true;
  jobs_.close();
  if (service_spinner_) service_spinner_->stop();  // returns once the calls in progress have returned
  register_srv_.shutdown();
  register_correspondences_srv_.shutdown();
  register_candidates_srv_.shutdown();
  {
    std::lock_guard<std::mutex> lock(shutdown_mutex_);
    destroying_ = true;
  }
  shutdown_cv_.notify_all();
  if (shutdown_watch_.joinable()) shutdown_watch_.join();
  if (worker_.joinable()) worker_.join();
}

// roscpp's shutdown (SIGINT, rosnode kill) waits for the service calls in progress before the server is
// destroyed, so the flag must go up as soon as it starts. roscpp has no hook for that: poll.
void RegistrationServer::watchForShutdown() {
  std::unique_lock<std::mutex> lock(shutdown_mutex_);
  while (!destroying_) {
    if (ros::isShuttingDown() || !ros::ok()) {
      stop_ = true;
      jobs_.close();
      return;
    }
    shutdown_cv_.wait_for(lock, std::chrono::milliseconds(50));
  }
}

ServerConfig RegistrationServer::config() const {
  std::lock_guard<std::mutex> lock(config_mutex_);
  return config_;
}

void RegistrationServer::onReconfigure(MacRegistrationConfig& c, std::uint32_t) {
  const ServerConfig current = config();
  ServerConfig next = current;
  RegistrationConfig algorithm = algorithmOf(current);
  std::vector<std::string> problems;
  try {
    fromReconfigure(c, algorithm);
    problems = validateConfig(algorithm);
  } catch (const std::invalid_argument& e) {
    problems.push_back(e.what());  // e.g. a negative count
  }
  if (!problems.empty()) {
    ROS_ERROR_STREAM(
        "mac_registration: reconfiguration refused, keeping the previous values:" << joined(problems));
    toReconfigure(algorithmOf(current), c);  // what dynamic_reconfigure reports must be what is in force
    return;
  }
  next.mac = algorithm.mac;
  next.features = algorithm.features;
  next.relocalization = algorithm.relocalization;
  if (sameReconfigurable(current, next)) return;  // e.g. the call that comes with setCallback
  // The private parameters the node read at start say what is in force, as dynamic_reconfigure's own do.
  for (const auto& key : reconfigurableKeys()) {
    std::string name = key;
    name[name.find('.')] = '/';
    const ParameterValue value = findParameter(key)->get(algorithm);
    if (const auto* d = std::get_if<double>(&value)) private_nh_.setParam(name, *d);
    if (const auto* i = std::get_if<long long>(&value)) private_nh_.setParam(name, static_cast<int>(*i));
  }
  std::lock_guard<std::mutex> lock(config_mutex_);
  config_ = next;
  ROS_INFO_STREAM("mac_registration: reconfigured:\n" << describeConfig(config_));
}

void RegistrationServer::onSource(const sensor_msgs::PointCloud2ConstPtr& source) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++inputs_received_;
  }
  sensor_msgs::PointCloud2ConstPtr target;
  {
    std::lock_guard<std::mutex> lock(target_mutex_);
    target = latest_target_;
  }
  if (!target) {
    ROS_WARN_THROTTLE(5.0, "mac_registration: source cloud received but no target yet on %s",
                      nh_.resolveName("target").c_str());
  }
  jobs_.put(Job{source, target, nullptr, ros::Time::now()});
}

void RegistrationServer::onSynchronized(const sensor_msgs::PointCloud2ConstPtr& source,
                                        const sensor_msgs::PointCloud2ConstPtr& target) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++inputs_received_;
  }
  jobs_.put(Job{source, target, nullptr, ros::Time::now()});
}

void RegistrationServer::onTarget(const sensor_msgs::PointCloud2ConstPtr& target) {
  std::lock_guard<std::mutex> lock(target_mutex_);
  latest_target_ = target;
}

void RegistrationServer::onCorrespondences(const mac_registration::CorrespondencesConstPtr& correspondences) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++inputs_received_;
  }
  jobs_.put(Job{nullptr, nullptr, correspondences, ros::Time::now()});
}

bool RegistrationServer::onRegister(Register::Request& request, Register::Response& response) {
  const ros::Time received = ros::Time::now();
  sensor_msgs::PointCloud2ConstPtr target;
  const bool own_target = std::size_t(request.target.width) * request.target.height > 0;
  if (own_target) {
    target = boost::make_shared<sensor_msgs::PointCloud2>(std::move(request.target));
  } else {
    std::lock_guard<std::mutex> lock(target_mutex_);
    target = latest_target_;
  }
  Outcome outcome;
  if (target) {
    outcome = registerClouds(request.source, target, received, !own_target);
  } else {
    outcome = missingTarget(request.source, "the request's target is empty and no target was received on ",
                            received);
  }
  publish(outcome);
  response.result = outcome.msg;
  return true;  // failures travel in result.success / status / message
}

bool RegistrationServer::onRegisterCorrespondences(RegisterCorrespondences::Request& request,
                                                   RegisterCorrespondences::Response& response) {
  Outcome outcome = registerCorrespondences(request.correspondences, ros::Time::now());
  publish(outcome);
  response.result = outcome.msg;
  return true;
}

bool RegistrationServer::onRegisterCandidates(RegisterCandidates::Request& request,
                                              RegisterCandidates::Response& response) {
  const ros::Time received = ros::Time::now();
  if (!request.targets.empty() && !request.correspondences.empty()) {
    response.message = "give targets or correspondences, not both";
    return true;
  }
  std::vector<Outcome> outcomes;
  if (!request.targets.empty()) {
    outcomes = registerCandidateClouds(request.source, request.targets, received);
  } else {
    for (const auto& set : request.correspondences)
      outcomes.push_back(registerCorrespondences(set, received));
  }
  if (outcomes.empty()) response.message = "no candidates: targets and correspondences are both empty";
  std::vector<CandidateRank> ranks;
  for (const Outcome& o : outcomes) ranks.push_back({bool(o.msg.success), o.msg.confidence, o.msg.inliers});
  for (const std::size_t k : bestFirst(ranks)) {
    response.results.push_back(outcomes[k].msg);
    response.candidates.push_back(static_cast<std::uint32_t>(k));
  }
  return true;
}

std::vector<RegistrationServer::Outcome> RegistrationServer::registerCandidateClouds(
    const sensor_msgs::PointCloud2& source, const std::vector<sensor_msgs::PointCloud2>& targets,
    const ros::Time& received) {
  const ServerConfig cfg = config();
  std::vector<Outcome> outcomes(targets.size());
  const CloudConversion source_cloud = toPointCloud(source);
  std::vector<PointCloud::ConstPtr> clouds(targets.size());
  std::vector<std::string> problems(targets.size());
  for (std::size_t k = 0; k < targets.size(); ++k) {
    const CloudConversion target = toPointCloud(targets[k]);
    clouds[k] = target.cloud;
    if (!source_cloud.error.empty()) problems[k] = "source cloud: " + source_cloud.error;
    if (!target.error.empty()) problems[k] = "target " + std::to_string(k) + ": " + target.error;
  }
  std::vector<CloudRegistrationResult> results;
  if (source_cloud.error.empty())
    results = registerCandidates(*source_cloud.cloud, clouds, cfg.features, cfg.mac, &stop_);
  for (std::size_t k = 0; k < targets.size(); ++k) {
    Outcome& outcome = outcomes[k];
    if (!problems[k].empty()) {
      outcome.msg = invalidInput(problems[k]);
    } else {
      fillFrontEndStats(results[k].features.stats, outcome.msg);
      fillResultMsg(results[k].registration, outcome.msg);
      fillStageTimes(results[k].times(), outcome.msg);
    }
    outcome.msg.header.frame_id = targets[k].header.frame_id;
    outcome.msg.child_frame_id = source.header.frame_id;
    stampResult(source.header.stamp, received, outcome);
  }
  return outcomes;
}

void RegistrationServer::workerLoop() {
  while (auto job = jobs_.take()) {
    if (stopRequested(&stop_)) break;
    try {
      Outcome outcome;
      if (job->correspondences) {
        outcome = registerCorrespondences(*job->correspondences, job->received);
      } else if (!job->target) {
        outcome = missingTarget(*job->source, "no target cloud received yet on ", job->received);
      } else {
        outcome = registerClouds(*job->source, job->target, job->received, true);
      }
      const auto publishing = Clock::now();
      publish(outcome);
      outcome.timing.publication_ms = millisecondsSince(publishing);
      const ros::Time stamp = outcome.msg.header.stamp;  // the input's, or its arrival when zero
      outcome.timing.latency_ms = (ros::Time::now() - stamp).toSec() * 1000.0;
      recordTiming(outcome.timing);
    } catch (const std::exception& e) {
      // Never let one bad message end the worker (or the nodelet manager with it).
      ROS_ERROR_STREAM("mac_registration: registration failed unexpectedly: " << e.what());
    }
  }
}

RegistrationServer::Outcome RegistrationServer::missingTarget(const sensor_msgs::PointCloud2& source,
                                                              const std::string& why,
                                                              const ros::Time& received) {
  Outcome outcome;
  outcome.msg = invalidInput(why + nh_.resolveName("target"));
  outcome.msg.header.frame_id = source.header.frame_id;
  outcome.msg.child_frame_id = source.header.frame_id;
  stampResult(source.header.stamp, received, outcome);
  return outcome;
}

void RegistrationServer::stampResult(const ros::Time& input_stamp, const ros::Time& received,
                                     Outcome& outcome) {
  outcome.odometry_stamp = input_stamp;
  outcome.msg.header.stamp = input_stamp;
  if (input_stamp.isZero()) {
    // On tf a zero stamp is older than every listener's cache (TF_OLD_DATA): use the arrival time.
    outcome.msg.header.stamp = received;
    outcome.msg.warnings.push_back(
        "the input's header.stamp is zero: the result is stamped with its arrival time (" +
        stampText(received) + ")" +
        (config().node.tf_mode == NodeParams::TfMode::kMapOdom ? " and the latest odometry is used" : ""));
  }
}

std::shared_ptr<const DescribedCloud> RegistrationServer::describeTarget(
    const sensor_msgs::PointCloud2& target, const FeatureParams& params, std::size_t& dropped) {
  const auto start = Clock::now();
  const CloudConversion cloud = toPointCloud(target);
  if (!cloud.error.empty()) throw std::invalid_argument("target cloud: " + cloud.error);
  // Reads the stop flag: a large target takes seconds to describe, longer than a shutdown may wait.
  auto described =
      std::make_shared<const DescribedCloud>(describeCloud(*cloud.cloud, params, "target", &stop_));
  dropped = cloud.dropped_non_finite;
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++target_descriptions_;
  last_target_description_ms_ = millisecondsSince(start);
  return described;
}

std::shared_ptr<const DescribedCloud> RegistrationServer::describedTarget(
    const sensor_msgs::PointCloud2ConstPtr& target, const FeatureParams& params, std::size_t& dropped,
    bool cache) {
  if (!cache) return describeTarget(*target, params, dropped);
  std::lock_guard<std::mutex> lock(target_cache_mutex_);
  const auto& cached = target_cache_;
  if (cached.message == target && cached.described && describedFor(*cached.described, params)) {
    dropped = cached.dropped;
    return cached.described;
  }
  auto described = describeTarget(*target, params, dropped);
  // Later registrations against the same target spend no time on it: the cached copy says so. It shares
  // the keypoints and descriptors (pointers), so this copies no points.
  auto reused = std::make_shared<DescribedCloud>(*described);
  reused->times = StageTimes();
  target_cache_ = {target, reused, dropped};
  return described;
}

RegistrationServer::Outcome RegistrationServer::registerClouds(const sensor_msgs::PointCloud2& source,
                                                               const sensor_msgs::PointCloud2ConstPtr& target,
                                                               const ros::Time& received, bool cache_target) {
  const ServerConfig cfg = config();
  Outcome outcome;
  auto start = Clock::now();
  const CloudConversion source_cloud = toPointCloud(source);
  outcome.timing.conversion_ms = millisecondsSince(start);
  std::size_t target_dropped = 0;
  std::shared_ptr<const DescribedCloud> target_described;
  if (!source_cloud.error.empty()) {
    outcome.msg = invalidInput("source cloud: " + source_cloud.error);
  } else {
    try {
      start = Clock::now();
      target_described = describedTarget(target, cfg.features, target_dropped, cache_target);
      outcome.timing.target_description_ms = millisecondsSince(start);
    } catch (const Cancelled& e) {
      outcome.msg = cancelled(e.what());  // nothing cached: the next registration describes it afresh
    } catch (const std::invalid_argument& e) {
      outcome.msg = invalidInput(e.what());
    }
  }
  if (target_described) {
    CloudRegistrationResult result =
        registerCloudToDescribed(*source_cloud.cloud, *target_described, cfg.features, cfg.mac, &stop_);
    fillFrontEndStats(result.features.stats, outcome.msg);
    fillResultMsg(result.registration, outcome.msg);
    fillStageTimes(result.times(), outcome.msg);
    outcome.timing.stages = withoutDescription(result.times(), target_described->times);
    outcome.msg.dropped_points = source_cloud.dropped_non_finite + target_dropped;
    if (outcome.msg.dropped_points > 0) {
      outcome.msg.warnings.push_back("dropped " + std::to_string(outcome.msg.dropped_points) +
                                     " points with NaN/Inf coordinates");
    }
    outcome.source_cloud = source_cloud.cloud;
    // Moved, not copied: the result is not needed beyond this.
    outcome.correspondences = std::move(result.features.correspondences);
    outcome.inliers = std::move(result.registration.inlier_indices);
    outcome.T_target_source = result.registration.T_target_source;
  }
  outcome.msg.header.frame_id = target->header.frame_id;
  outcome.msg.child_frame_id = source.header.frame_id;
  stampResult(source.header.stamp, received, outcome);
  return outcome;
}

RegistrationServer::Outcome RegistrationServer::registerCorrespondences(
    const mac_registration::Correspondences& correspondences, const ros::Time& received) {
  const ServerConfig cfg = config();
  Outcome outcome;
  try {
    outcome.correspondences = toCorrespondences(correspondences);
    const MacResult result =
        mac_registration::registerCorrespondences(outcome.correspondences, cfg.mac, &stop_);
    fillResultMsg(result, outcome.msg);
    outcome.inliers = result.inlier_indices;
    outcome.T_target_source = result.T_target_source;
  } catch (const std::invalid_argument& e) {
    outcome.msg = invalidInput(std::string("correspondences: ") + e.what());
  }
  outcome.msg.header.frame_id = correspondences.header.frame_id;
  outcome.msg.child_frame_id = correspondences.source_frame;
  stampResult(correspondences.header.stamp, received, outcome);
  return outcome;
}

void RegistrationServer::publishTf(Outcome& outcome, const NodeParams& node) {
  auto& msg = outcome.msg;
  const auto skip = [&msg](const std::string& why) {
    msg.warnings.push_back("tf not published: " + why);
    ROS_WARN_STREAM_THROTTLE(5.0, "mac_registration: tf not published: " << why);
  };
  if (msg.header.frame_id.empty() || msg.child_frame_id.empty()) {
    return skip("the target or source frame_id is empty");
  }
  if (msg.header.frame_id == msg.child_frame_id) {
    return skip("source and target share the frame '" + msg.header.frame_id + "'");
  }
  if (node.tf_mode == NodeParams::TfMode::kTargetSource) {
    geometry_msgs::TransformStamped tf;
    tf.header = msg.header;
    tf.child_frame_id = msg.child_frame_id;
    tf.transform = msg.transform;
    tf_broadcaster_.sendTransform(tf);
    return;
  }
  if (msg.header.frame_id == node.odom_frame) {
    return skip("the target frame is the odom frame '" + node.odom_frame + "'");
  }
  // REP-105: the target frame becomes the parent of odom, keeping odom -> source continuous. Without the
  // odometry at the scan's time there is no correction to give: that is a failure, not a warning.
  geometry_msgs::TransformStamped odom_source;
  try {
    odom_source = tf_buffer_.lookupTransform(node.odom_frame, msg.child_frame_id, outcome.odometry_stamp,
                                             ros::Duration(node.tf_timeout));
  } catch (const tf2::TransformException& e) {
    std::ostringstream why;
    why << "map_odom mode: no transform " << node.odom_frame << " <- " << msg.child_frame_id << " at "
        << (outcome.odometry_stamp.isZero() ? std::string("the latest time")
                                            : stampText(outcome.odometry_stamp))
        << " within tf_timeout = " << node.tf_timeout << " s (" << e.what() << "); the registration found "
        << msg.inliers << " inliers, " << msg.header.frame_id << " -> " << node.odom_frame
        << " keeps its previous correction";
    return markFailed(msg, mac_registration::RegistrationResult::MISSING_ODOMETRY, why.str());
  }
  const Eigen::Isometry3d T_target_odom =
      outcome.T_target_source * tf2::transformToEigen(odom_source).inverse();
  if (!T_target_odom.matrix().allFinite()) {
    return markFailed(
        msg, mac_registration::RegistrationResult::INTERNAL_ERROR,
        "map_odom mode: the " + msg.header.frame_id + " -> " + node.odom_frame + " transform is not finite");
  }
  map_odom_->setCorrection(msg.header.frame_id, node.odom_frame, T_target_odom);
}

void RegistrationServer::publish(Outcome& outcome) {
  // Shutting down: the caller still gets its (cancelled) result, the topics and tf no longer matter.
  if (stopRequested(&stop_)) return;
  auto& msg = outcome.msg;
  const ServerConfig cfg = config();
  if (msg.success && !outcome.T_target_source.matrix().allFinite()) {
    markFailed(msg, mac_registration::RegistrationResult::INTERNAL_ERROR, "the transform is not finite");
  }
  if (msg.success && cfg.node.publish_tf) publishTf(outcome, cfg.node);
  result_pub_.publish(msg);
  if (msg.success) {
    const Eigen::Vector3d t = outcome.T_target_source.translation();
    const double angle = Eigen::AngleAxisd(outcome.T_target_source.linear()).angle() * 180.0 / M_PI;
    ROS_INFO(
        "mac_registration: %s <- %s: t = [%.3f %.3f %.3f] m, rotation %.2f deg, %u inliers of %u, %.1f ms",
        msg.header.frame_id.c_str(), msg.child_frame_id.c_str(), t.x(), t.y(), t.z(), angle, msg.inliers,
        msg.correspondences, msg.time_total_ms);
  } else {
    ROS_WARN_STREAM_THROTTLE(
        1.0, "mac_registration: registration failed (" << statusName(msg.status) << "): " << msg.message);
  }
  const std_msgs::Header& target_header = msg.header;
  if (msg.success && outcome.source_cloud && aligned_pub_.getNumSubscribers() > 0) {
    aligned_pub_.publish(toPointCloud2(*outcome.source_cloud, outcome.T_target_source, target_header));
  }
  if (msg.success && markers_pub_.getNumSubscribers() > 0 && outcome.correspondences.size() > 0) {
    const double width = std::max(0.005, 0.2 * cfg.features.voxel_size);  // [m]
    markers_pub_.publish(correspondenceMarkers(outcome.correspondences, outcome.inliers,
                                               outcome.T_target_source, target_header, width,
                                               cfg.node.max_marker_lines));
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++registrations_;
  failures_ += !msg.success;
  unverified_ += msg.status == mac_registration::RegistrationResult::UNVERIFIED;
  last_result_ = msg;
}

void RegistrationServer::reportDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  if (registrations_ == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "waiting for input");
  } else if (last_result_.success) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "last registration succeeded");
  } else if (last_result_.status == mac_registration::RegistrationResult::UNVERIFIED) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "last registration not verified (no tf sent): " + last_result_.message);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   "last registration failed: " + last_result_.message);
  }
  status.add("kernels", kernelsInUse());
  status.add("registrations", registrations_);
  status.add("failures", failures_);
  status.add("rejected by the verification", unverified_);
  status.add("last confidence", last_result_.confidence);
  status.add("inputs dropped (worker busy)", jobs_.dropped());
  status.add("last inliers", last_result_.inliers);
  status.add("last total time [ms]", last_result_.time_total_ms);
  status.add("inputs received", inputs_received_);
  status.add("target descriptions", target_descriptions_);
  status.add("last target description [ms]", last_target_description_ms_);
  reportRecentTimes(recent_times_, status);
}

void RegistrationServer::recordTiming(const Timing& timing) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  recent_times_.push_back(timing);
  if (recent_times_.size() > kTimedResults) recent_times_.pop_front();
}

}  // namespace mac_registration
