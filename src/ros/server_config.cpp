#include "mac_registration/ros/server_config.hpp"

#include <XmlRpcValue.h>

#include <set>
#include <sstream>

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {
namespace {

// The parameter server's types map onto the table's; a string where a number belongs is refused there.
ParameterValue toParameterValue(XmlRpc::XmlRpcValue& value) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(value);
    case XmlRpc::XmlRpcValue::TypeInt:
      return static_cast<long long>(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return static_cast<double>(value);
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(value);
    default:
      throw std::invalid_argument("not a number, boolean or name");
  }
}

// Every table key "section.name" is read from ~section/name (and "num_threads" from ~num_threads) with its
// type; a name in one of the table's sections that the table does not know is reported, so that a typo
// does not silently leave a default in place.
void loadAlgorithmParams(const ros::NodeHandle& nh, RegistrationConfig& config,
                         std::vector<std::string>& problems) {
  std::set<std::string> sections;
  for (const auto& p : parameterTable()) {
    const auto dot = p.key.find('.');
    std::string name = p.key;
    if (dot != std::string::npos) {
      sections.insert(p.key.substr(0, dot));
      name[dot] = '/';
    }
    XmlRpc::XmlRpcValue value;
    if (!nh.getParam(name, value)) continue;
    try {
      setParameter(config, p.key, toParameterValue(value));
    } catch (const std::exception& e) {
      problems.push_back("~" + name + ": " + e.what());
    }
  }
  for (const auto& section : sections) {
    XmlRpc::XmlRpcValue values;
    if (!nh.getParam(section, values)) continue;
    if (values.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      problems.push_back("~" + section + " must be a dictionary of parameters");
      continue;
    }
    for (auto& entry : values) {
      if (!findParameter(section + "." + entry.first))
        problems.push_back("~" + section + "/" + entry.first + ": unknown parameter");
    }
  }
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
  RegistrationConfig algorithm{config.mac, config.features};
  loadAlgorithmParams(nh, algorithm, problems);
  config.mac = algorithm.mac;
  config.features = algorithm.features;
  loadNodeParams(nh, config.node, problems);
  for (const auto& p : validateConfig(algorithm)) problems.push_back(p);
  return problems;
}

std::string describeConfig(const ServerConfig& c) {
  std::ostringstream text;
  text << "target_mode="
       << (c.node.target_mode == NodeParams::TargetMode::kLatest ? "latest" : "synchronized")
       << " publish_tf=" << (c.node.publish_tf ? "true" : "false")
       << " tf_mode=" << (c.node.tf_mode == NodeParams::TfMode::kTargetSource ? "target_source" : "map_odom");
  if (c.node.tf_mode == NodeParams::TfMode::kMapOdom) {
    text << " (odom_frame=" << c.node.odom_frame << ", re-sent at " << c.node.map_odom_rate
         << " Hz, stamped now + " << c.node.transform_tolerance << " s)";
  }
  text << " service_threads=" << c.node.service_threads << "\n"
       << describeConfig(RegistrationConfig{c.mac, c.features});
  return text.str();
}

}  // namespace mac_registration
