#include "mac_registration/ros/server_config.hpp"

#include <XmlRpcValue.h>

#include <set>
#include <stdexcept>

#include "table_entries.hpp"

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

using Node = NodeParams;
using Range = ParameterRange;

const table_entries::Names<Node::TargetMode> kTargetModes{
    {{"latest", Node::TargetMode::kLatest}, {"synchronized", Node::TargetMode::kSynchronized}}};
const table_entries::Names<Node::TfMode> kTfModes{
    {{"target_source", Node::TfMode::kTargetSource}, {"map_odom", Node::TfMode::kMapOdom}}};

std::vector<BasicParameter<Node>> makeNodeTable() {
  using namespace table_entries;
  return {
      choice<Node>("target_mode", MAC_FIELD(target_mode), kTargetModes,
                   "the latest cloud on target (a latched map, a keyframe), or the one synchronized with the "
                   "source by stamp"),
      real<Node>("sync_slop", MAC_FIELD(sync_slop), "s", Range::atLeast(0),
                 "largest stamp difference of a synchronized pair"),
      boolean<Node>("publish_tf", MAC_FIELD(publish_tf), "broadcast successful results on tf"),
      choice<Node>(
          "tf_mode", MAC_FIELD(tf_mode), kTfModes,
          "target_source: target_frame -> source_frame; map_odom (REP-105): target_frame -> odom_frame"),
      text<Node>("odom_frame", MAC_FIELD(odom_frame), "map_odom: the frame under the target frame"),
      real<Node>("tf_timeout", MAC_FIELD(tf_timeout), "s", Range::atLeast(0),
                 "map_odom: wait for odom_frame -> source_frame at the scan's stamp"),
      real<Node>("map_odom_rate", MAC_FIELD(map_odom_rate), "Hz", Range::openClosed(0, 1000),
                 "map_odom: re-send rate of the latest correction"),
      real<Node>("transform_tolerance", MAC_FIELD(transform_tolerance), "s", Range::closed(0, 10),
                 "map_odom: post-dating of each send"),
      integer<Node>("max_marker_lines", MAC_FIELD(max_marker_lines), "lines", Range::atLeast(0),
                    "outlier lines drawn at most on ~correspondence_markers (inliers are all drawn)"),
      integer<Node>("service_threads", MAC_FIELD(service_threads), "threads", Range::closed(1, 64),
                    "threads answering ~register and ~register_correspondences"),
  };
}

// Each entry from ~key with its type: a value of the wrong type or name is reported, not replaced by the
// default.
void loadNodeParams(const ros::NodeHandle& nh, NodeParams& node, std::vector<std::string>& problems) {
  for (const auto& p : nodeParameterTable()) {
    XmlRpc::XmlRpcValue value;
    if (!nh.getParam(p.key, value)) continue;
    std::string given;
    try {
      const ParameterValue typed = toParameterValue(value);
      given = "'" + formatParameterValue(typed) + "': ";
      p.set(node, typed);
    } catch (const std::exception& e) {
      problems.push_back("~" + p.key + ": " + given + e.what());
    }
  }
}

}  // namespace

const std::vector<BasicParameter<NodeParams>>& nodeParameterTable() {
  static const std::vector<BasicParameter<NodeParams>> table = makeNodeTable();
  return table;
}

std::vector<std::string> validateNodeParams(const NodeParams& node) {
  std::vector<std::string> problems;
  for (const auto& p : nodeParameterTable()) {
    std::string problem = rangeProblem(p, p.get(node));
    if (!problem.empty()) problems.push_back(std::move(problem));
  }
  if (node.tf_mode == NodeParams::TfMode::kMapOdom && node.odom_frame.empty())
    problems.push_back("odom_frame must be set when tf_mode is map_odom");
  return problems;
}

std::vector<std::string> loadServerConfig(const ros::NodeHandle& nh, ServerConfig& config) {
  std::vector<std::string> problems;
  RegistrationConfig algorithm{config.mac, config.features, config.relocalization};
  loadAlgorithmParams(nh, algorithm, problems);
  config.mac = algorithm.mac;
  config.features = algorithm.features;
  config.relocalization = algorithm.relocalization;
  loadNodeParams(nh, config.node, problems);
  for (auto& p : validateNodeParams(config.node)) problems.push_back(std::move(p));
  for (auto& p : validateConfig(algorithm)) problems.push_back(std::move(p));
  return problems;
}

std::vector<std::string> loadRegistrationConfig(const ros::NodeHandle& nh, RegistrationConfig& config) {
  std::vector<std::string> problems;
  loadAlgorithmParams(nh, config, problems);
  for (auto& p : validateConfig(config)) problems.push_back(std::move(p));
  return problems;
}

std::string describeConfig(const ServerConfig& c) {
  std::string text;
  for (const auto& p : nodeParameterTable()) text += "  " + describeParameter(p, p.get(c.node)) + "\n";
  return text + describeConfig(RegistrationConfig{c.mac, c.features, c.relocalization});
}

}  // namespace mac_registration
