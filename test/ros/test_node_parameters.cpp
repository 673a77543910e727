// The node's own parameter table: its ranges are what the node refuses, and config/registration_node.yaml
// and the README's table of the node's parameters agree with it (no roscore).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/ros/server_config.hpp"

namespace mac_registration {
namespace {

// The node table's entry of `key`, or nullptr.
const BasicParameter<NodeParams>* findNodeParameter(const std::string& key) {
  for (const auto& p : nodeParameterTable()) {
    if (p.key == key) return &p;
  }
  return nullptr;
}

bool mentions(const std::vector<std::string>& problems, const std::string& key) {
  for (const auto& p : problems) {
    if (p.find(key) != std::string::npos) return true;
  }
  return false;
}

// The node's entry of `key`, else the algorithm table's (num_threads is documented with the node's).
const ParameterInfo* anyParameter(const std::string& key) {
  if (const auto* p = findNodeParameter(key)) return p;
  return findParameter(key);
}

std::string defaultOf(const std::string& key) {
  if (const auto* p = findNodeParameter(key)) return formatParameterValue(p->get(NodeParams{}));
  return formatParameterValue(findParameter(key)->get(RegistrationConfig{}));
}

// A cell of the README as the table would write it.
std::string normalized(const ParameterInfo& p, const std::string& cell) {
  return formatParameterValue(parseParameterValue(p, cell));
}

// What the README's range column says: the range of a number, the names of a choice, "–" otherwise.
std::string rangeColumn(const ParameterInfo& p) {
  switch (p.type) {
    case ParameterType::kReal:
    case ParameterType::kInteger:
    case ParameterType::kCount:
      return p.range.text();
    case ParameterType::kChoice: {
      std::string names;
      for (const auto& c : p.choices) names += (names.empty() ? "" : ", ") + c;
      return names;
    }
    default:
      return "–";
  }
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> cellsOf(const std::string& row) {
  std::vector<std::string> cells;
  std::stringstream in(row.substr(1));
  for (std::string cell; std::getline(in, cell, '|');) {
    const auto first = cell.find_first_not_of(' ');
    cells.push_back(first == std::string::npos ? ""
                                               : cell.substr(first, cell.find_last_not_of(' ') - first + 1));
  }
  return cells;
}

TEST(NodeParameters, KeysAreUniqueDocumentedAndNotTheAlgorithms) {
  std::set<std::string> keys;
  for (const auto& p : nodeParameterTable()) {
    EXPECT_TRUE(keys.insert(p.key).second) << "duplicate key " << p.key;
    EXPECT_FALSE(p.doc.empty()) << p.key;
    EXPECT_EQ(findNodeParameter(p.key), &p);
    EXPECT_EQ(findParameter(p.key), nullptr) << p.key << " is a key of the algorithm's table too";
    EXPECT_EQ(p.key.find('.'), std::string::npos) << p.key << ": the node reads ~" << p.key;
  }
  EXPECT_TRUE(validateNodeParams(NodeParams{}).empty());
}

// Just outside each bound is refused with a message naming the key, each bound itself as its range says.
TEST(NodeParameters, RangesAreWhatTheNodeRefuses) {
  for (const auto& p : nodeParameterTable()) {
    if (p.type != ParameterType::kReal && p.type != ParameterType::kInteger) continue;
    const bool whole = p.type == ParameterType::kInteger;
    const auto refused = [&](double value) {
      NodeParams node;
      p.set(node, whole ? ParameterValue(static_cast<long long>(value)) : ParameterValue(value));
      return mentions(validateNodeParams(node), p.key);
    };
    const double step = whole ? 1.0 : 1e-6;
    ASSERT_TRUE(std::isfinite(p.range.min)) << p.key;
    EXPECT_TRUE(refused(p.range.min - step)) << p.key;
    EXPECT_EQ(refused(p.range.min), p.range.min_open) << p.key;
    if (std::isfinite(p.range.max)) {
      EXPECT_TRUE(refused(p.range.max + step)) << p.key;
      EXPECT_EQ(refused(p.range.max), p.range.max_open) << p.key;
    }
  }
  NodeParams node;
  node.map_odom_rate = 2000.0;
  node.tf_mode = NodeParams::TfMode::kMapOdom;
  node.odom_frame = "";
  const auto problems = validateNodeParams(node);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_EQ(problems[0], "map_odom_rate = 2000 [Hz] is out of range: must be in (0, 1000].");
  EXPECT_EQ(problems[1], "odom_frame must be set when tf_mode is map_odom");
}

TEST(NodeParameters, TypedValuesAreChecked) {
  NodeParams node;
  findNodeParameter("tf_mode")->set(node, std::string("map_odom"));
  EXPECT_EQ(node.tf_mode, NodeParams::TfMode::kMapOdom);
  EXPECT_THROW(findNodeParameter("tf_mode")->set(node, std::string("odom_map")), std::invalid_argument);
  EXPECT_THROW(findNodeParameter("service_threads")->set(node, 2.5), std::invalid_argument);
  EXPECT_THROW(findNodeParameter("publish_tf")->set(node, std::string("yes")), std::invalid_argument);
  findNodeParameter("sync_slop")->set(node, 1LL);  // an integer where a real is expected is fine
  EXPECT_EQ(node.sync_slop, 1.0);
}

TEST(NodeParameters, TheStartUpLogListsEveryParameter) {
  const std::string text = describeConfig(ServerConfig{});
  for (const auto& p : nodeParameterTable())
    EXPECT_NE(text.find("  " + p.key + " = "), std::string::npos) << p.key;
  EXPECT_NE(text.find("map_odom_rate = 20 [Hz]"), std::string::npos) << text;
  EXPECT_NE(text.find("graph.t_cmp = 0.99"), std::string::npos) << text;
}

// The yaml holds every key of the node's table at its default, and each range in the comment above it.
TEST(NodeParameters, TheNodesYamlDocumentsTheTable) {
  const std::string path = std::string(MAC_CONFIG_DIR) + "/registration_node.yaml";
  std::map<std::string, std::string> values;
  readPresetFile(path, [&](const std::string& key, const std::string& value) { values[key] = value; });
  for (const auto& p : nodeParameterTable()) {
    ASSERT_TRUE(values.count(p.key)) << p.key << " is not in " << path;
    EXPECT_EQ(normalized(p, values[p.key]), defaultOf(p.key)) << p.key;
  }
  for (const auto& entry : values) EXPECT_NE(findNodeParameter(entry.first), nullptr) << entry.first;

  // The comment lines above a key, or above the first of a group of keys, document it.
  std::map<std::string, std::string> comments;
  std::ifstream in(path);
  std::string comment;
  bool after_key = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("#", 0) == 0) {
      if (after_key) comment.clear();
      comment += line + "\n";
      after_key = false;
    } else if (!line.empty()) {
      comments[line.substr(0, line.find(':'))] = comment;
      after_key = true;
    }
  }
  for (const auto& p : nodeParameterTable()) {
    if (p.type == ParameterType::kReal || p.type == ParameterType::kInteger) {
      EXPECT_NE(comments[p.key].find(p.range.text()), std::string::npos)
          << p.key << ": its comment does not say " << p.range.text() << "\n"
          << comments[p.key];
    }
    for (const auto& choice : p.choices) EXPECT_NE(comments[p.key].find(choice), std::string::npos) << p.key;
  }
}

// The README's table of the node's parameters: one row per entry, with the table's unit, default and range.
TEST(NodeParameters, TheReadmeTableIsTheTable) {
  const std::string readme = readFile(std::string(MAC_SOURCE_DIR) + "/README.md");
  const auto start = readme.find("The node's own parameters");
  ASSERT_NE(start, std::string::npos);
  std::stringstream section(readme.substr(start, readme.find("\n#", start) - start));
  std::set<std::string> rows;
  for (std::string line; std::getline(section, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    const auto cells = cellsOf(line);
    ASSERT_GE(cells.size(), 5u) << line;
    const std::string key = cells[0].substr(1, cells[0].size() - 2);
    rows.insert(key);
    const ParameterInfo* p = anyParameter(key);
    ASSERT_NE(p, nullptr) << key << " is in no table";
    EXPECT_EQ(cells[1], p->unit.empty() ? "–" : p->unit) << key;
    EXPECT_EQ(normalized(*p, cells[2]), defaultOf(key)) << key;
    EXPECT_EQ(cells[3], rangeColumn(*p)) << key;
  }
  for (const auto& p : nodeParameterTable()) EXPECT_TRUE(rows.count(p.key)) << p.key << " has no README row";
}

}  // namespace
}  // namespace mac_registration
