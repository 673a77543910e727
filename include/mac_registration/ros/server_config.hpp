#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "mac_registration/config/parameter_table.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {

// What the ROS node does with its inputs and results (the algorithm's parameters are in MacParams and
// FeatureParams). Each field is an entry of nodeParameterTable(), which holds its range, choices, unit
// and meaning; config/registration_node.yaml documents them.
struct NodeParams {
  enum class TargetMode { kLatest, kSynchronized };
  enum class TfMode { kTargetSource, kMapOdom };

  TargetMode target_mode = TargetMode::kLatest;
  double sync_slop = 0.05;  // [s] largest stamp difference of a synchronized source/target pair
  bool publish_tf = true;
  TfMode tf_mode = TfMode::kTargetSource;
  std::string odom_frame = "odom";   // map_odom mode: the frame whose parent becomes the target frame
  double tf_timeout = 0.1;           // [s] waiting for odom_frame <- source frame at the scan's stamp
  double map_odom_rate = 20.0;       // [Hz] map_odom mode: how often the latest correction is re-sent
  double transform_tolerance = 0.1;  // [s] map_odom mode: how far ahead of now map -> odom is stamped
  int max_marker_lines = 500;        // outlier lines drawn at most (inliers are all drawn)
  int service_threads = 2;           // [count] threads answering ~register and ~register_correspondences
};

// The node's own parameters, private and top-level (~target_mode, ~map_odom_rate, ...), as entries of the
// same type as the algorithm's table: loadServerConfig() reads and checks them from here and the start-up
// log lists them. (num_threads is the algorithm table's.)
const std::vector<BasicParameter<NodeParams>>& nodeParameterTable();

// Every problem with the node's parameters: values outside their ranges, then the rules between them.
std::vector<std::string> validateNodeParams(const NodeParams& params);

struct ServerConfig {
  NodeParams node;
  FeatureParams features;
  MacParams mac;
  RelocalizationParams relocalization;
};

// Reads the private parameters (sections graph/, cliques/, selection/, hypotheses/, evaluation/,
// refinement/, features/ as in config/*.yaml, plus the node's own) over the defaults in `config`.
// Returns every problem as a sentence naming the parameter; empty when the configuration is usable.
std::vector<std::string> loadServerConfig(const ros::NodeHandle& private_nh, ServerConfig& config);

// The effective configuration, one parameter a line ("key = value [unit]"), the node's first, for the
// start-up log.
std::string describeConfig(const ServerConfig& config);

// The algorithm's parameters alone (every table key from ~section/name), read over the values in `config`
// and checked: every problem, each naming its parameter; empty when usable.
std::vector<std::string> loadRegistrationConfig(const ros::NodeHandle& private_nh,
                                                RegistrationConfig& config);

}  // namespace mac_registration
