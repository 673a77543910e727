#include "mac_registration/ros/server_config.hpp"

#include <XmlRpcValue.h>

#include <sstream>

#include "cli_config.hpp"

namespace mac_registration {
namespace {

std::string toText(XmlRpc::XmlRpcValue& value) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(value) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream text;
      text.precision(17);
      text << static_cast<double>(value);
      return text.str();
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(value);
    default:
      throw std::invalid_argument("unsupported value type");
  }
}

// The algorithm's sections go through the same key tables as the command-line presets, so a key means the
// same in both.
void loadAlgorithmSections(const ros::NodeHandle& nh, MacParams& params, FeatureParams& features,
                           std::vector<std::string>& problems) {
  for (const std::string section :
       {"graph", "cliques", "selection", "hypotheses", "evaluation", "refinement", "features"}) {
    XmlRpc::XmlRpcValue values;
    if (!nh.getParam(section, values)) continue;
    if (values.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      problems.push_back("~" + section + " must be a dictionary of parameters");
      continue;
    }
    for (auto& [name, value] : values) {
      const std::string key = section + "." + name;
      try {
        if (section == "features") {
          setFeatureParam(features, key, toText(value));
        } else {
          setParam(params, key, toText(value));
        }
      } catch (const std::exception& e) {
        problems.push_back("~" + section + "/" + name + ": " + e.what());
      }
    }
  }
  int threads = params.num_threads;
  nh.param("num_threads", threads, threads);
  params.num_threads = threads;
  features.num_threads = threads;
}

std::string number(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

void loadNodeParams(const ros::NodeHandle& nh, NodeParams& p, std::vector<std::string>& problems) {
  std::string target_mode = p.target_mode == NodeParams::TargetMode::kLatest ? "latest" : "synchronized";
  nh.param("target_mode", target_mode, target_mode);
  if (target_mode == "latest")
    p.target_mode = NodeParams::TargetMode::kLatest;
  else if (target_mode == "synchronized")
    p.target_mode = NodeParams::TargetMode::kSynchronized;
  else
    problems.push_back("~target_mode = '" + target_mode + "' must be 'latest' or 'synchronized'");

  nh.param("sync_slop", p.sync_slop, p.sync_slop);
  if (!(p.sync_slop >= 0.0)) problems.push_back("~sync_slop must be >= 0 [s]");
  nh.param("publish_tf", p.publish_tf, p.publish_tf);
  std::string tf_mode = p.tf_mode == NodeParams::TfMode::kTargetSource ? "target_source" : "map_odom";
  nh.param("tf_mode", tf_mode, tf_mode);
  if (tf_mode == "target_source")
    p.tf_mode = NodeParams::TfMode::kTargetSource;
  else if (tf_mode == "map_odom")
    p.tf_mode = NodeParams::TfMode::kMapOdom;
  else
    problems.push_back("~tf_mode = '" + tf_mode + "' must be 'target_source' or 'map_odom'");
  nh.param("odom_frame", p.odom_frame, p.odom_frame);
  if (p.tf_mode == NodeParams::TfMode::kMapOdom && p.odom_frame.empty()) {
    problems.push_back("~odom_frame must be set when ~tf_mode is map_odom");
  }
  nh.param("tf_timeout", p.tf_timeout, p.tf_timeout);
  if (!(p.tf_timeout >= 0.0)) problems.push_back("~tf_timeout must be >= 0 [s]");
  nh.param("map_odom_rate", p.map_odom_rate, p.map_odom_rate);
  if (!(p.map_odom_rate > 0.0 && p.map_odom_rate <= 1000.0)) {
    problems.push_back("~map_odom_rate = " + number(p.map_odom_rate) + " must be in (0, 1000] [Hz]");
  }
  nh.param("transform_tolerance", p.transform_tolerance, p.transform_tolerance);
  if (!(p.transform_tolerance >= 0.0 && p.transform_tolerance <= 10.0)) {
    problems.push_back("~transform_tolerance = " + number(p.transform_tolerance) + " must be in [0, 10] [s]");
  }
  nh.param("max_marker_lines", p.max_marker_lines, p.max_marker_lines);
  if (p.max_marker_lines < 0) problems.push_back("~max_marker_lines must be >= 0");
  nh.param("service_threads", p.service_threads, p.service_threads);
  if (p.service_threads < 1 || p.service_threads > 64) {
    problems.push_back("~service_threads = " + std::to_string(p.service_threads) + " must be in [1, 64]");
  }
}

}  // namespace

std::vector<std::string> loadServerConfig(const ros::NodeHandle& nh, ServerConfig& config) {
  std::vector<std::string> problems;
  loadAlgorithmSections(nh, config.mac, config.features, problems);
  loadNodeParams(nh, config.node, problems);
  for (const auto& p : validateParams(config.mac)) problems.push_back(p);
  for (const auto& p : validateFeatureParams(config.features)) problems.push_back(p);
  return problems;
}

std::string describeConfig(const ServerConfig& c) {
  std::ostringstream text;
  const auto& g = c.mac.graph;
  text << "target_mode="
       << (c.node.target_mode == NodeParams::TargetMode::kLatest ? "latest" : "synchronized")
       << " publish_tf=" << (c.node.publish_tf ? "true" : "false")
       << " tf_mode=" << (c.node.tf_mode == NodeParams::TfMode::kTargetSource ? "target_source" : "map_odom");
  if (c.node.tf_mode == NodeParams::TfMode::kMapOdom) {
    text << " (odom_frame=" << c.node.odom_frame << ", re-sent at " << c.node.map_odom_rate
         << " Hz, stamped now + " << c.node.transform_tolerance << " s)";
  }
  text << " service_threads=" << c.node.service_threads
       << "\n  features: voxel_size=" << c.features.voxel_size << " m, normal radius x"
       << c.features.normal_radius_factor << ", FPFH radius x" << c.features.feature_radius_factor
       << ", max_correspondences=" << c.features.max_correspondences
       << ", mutual=" << c.features.mutual_filter
       << "\n  graph: " << (g.score == CompatibilityScore::kGaussian ? "gaussian sigma=" : "quadratic tau=")
       << (g.score == CompatibilityScore::kGaussian ? g.gaussian_sigma : g.quadratic_threshold)
       << " m, t_cmp=" << g.t_cmp << ", second_order=" << g.second_order
       << "\n  cliques: min_size=" << c.mac.cliques.min_clique_size
       << ", max_cliques=" << c.mac.cliques.max_cliques << ", time_limit=" << c.mac.cliques.time_limit
       << " s, max_degeneracy=" << c.mac.cliques.max_degeneracy
       << "\n  evaluation: tau=" << c.mac.evaluation.inlier_threshold
       << " m, min_inliers=" << c.mac.evaluation.min_inliers << ", refinement=" << c.mac.refinement.enabled;
  return text.str();
}

}  // namespace mac_registration
