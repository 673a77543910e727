#include "cli_config.hpp"

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <stdexcept>

namespace mac_registration {
namespace {

double toDouble(const std::string& key, const std::string& value) {
  try {
    std::size_t used = 0;
    const double v = std::stod(value, &used);
    if (used == value.size()) return v;
  } catch (const std::exception&) {
  }
  throw std::invalid_argument(key + ": '" + value + "' is not a number");
}

// A count: a negative value would wrap around to a huge size_t and pass every range check.
std::size_t toCount(const std::string& key, const std::string& value) {
  const double v = toDouble(key, value);
  if (v < 0.0 || v != std::floor(v)) throw std::invalid_argument(key + ": '" + value + "' is not a count");
  return static_cast<std::size_t>(v);
}

bool toBool(const std::string& key, const std::string& value) {
  if (value == "true" || value == "1") return true;
  if (value == "false" || value == "0") return false;
  throw std::invalid_argument(key + ": '" + value + "' is not true/false");
}

template <typename Enum>
Enum toEnum(const std::string& key, const std::string& value, const std::map<std::string, Enum>& names) {
  const auto it = names.find(value);
  if (it != names.end()) return it->second;
  std::string allowed;
  for (const auto& [name, _] : names) allowed += (allowed.empty() ? "" : ", ") + name;
  throw std::invalid_argument(key + ": '" + value + "' is not one of " + allowed);
}

using Setter = std::function<void(MacParams&, const std::string& key, const std::string& value)>;

const std::map<std::string, Setter>& setters() {
  static const std::map<std::string, Setter> table = {
      {"graph.score",
       [](MacParams& p, const std::string& k, const std::string& v) {
         p.graph.score = toEnum<CompatibilityScore>(
             k, v,
             {{"gaussian", CompatibilityScore::kGaussian}, {"quadratic", CompatibilityScore::kQuadratic}});
       }},
      {"graph.gaussian_sigma",
       [](MacParams& p, auto& k, auto& v) { p.graph.gaussian_sigma = toDouble(k, v); }},
      {"graph.quadratic_threshold",
       [](MacParams& p, auto& k, auto& v) { p.graph.quadratic_threshold = toDouble(k, v); }},
      {"graph.t_cmp", [](MacParams& p, auto& k, auto& v) { p.graph.t_cmp = toDouble(k, v); }},
      {"graph.second_order", [](MacParams& p, auto& k, auto& v) { p.graph.second_order = toBool(k, v); }},
      {"graph.max_correspondences",
       [](MacParams& p, auto& k, auto& v) { p.graph.max_correspondences = toCount(k, v); }},
      {"graph.max_edges", [](MacParams& p, auto& k, auto& v) { p.graph.max_edges = toCount(k, v); }},
      {"graph.max_second_order_work",
       [](MacParams& p, auto& k, auto& v) { p.graph.max_second_order_work = toDouble(k, v); }},
      {"graph.dense_mean_degree",
       [](MacParams& p, auto& k, auto& v) { p.graph.dense_mean_degree = toDouble(k, v); }},
      {"cliques.min_clique_size",
       [](MacParams& p, auto& k, auto& v) { p.cliques.min_clique_size = int(toDouble(k, v)); }},
      {"cliques.max_clique_size",
       [](MacParams& p, auto& k, auto& v) { p.cliques.max_clique_size = int(toDouble(k, v)); }},
      {"cliques.max_degeneracy",
       [](MacParams& p, auto& k, auto& v) { p.cliques.max_degeneracy = int(toDouble(k, v)); }},
      {"cliques.max_cliques", [](MacParams& p, auto& k, auto& v) { p.cliques.max_cliques = toCount(k, v); }},
      {"cliques.time_limit", [](MacParams& p, auto& k, auto& v) { p.cliques.time_limit = toDouble(k, v); }},
      {"cliques.max_pruning_rounds",
       [](MacParams& p, auto& k, auto& v) { p.cliques.max_pruning_rounds = int(toDouble(k, v)); }},
      {"cliques.pruning_keep_fraction",
       [](MacParams& p, auto& k, auto& v) { p.cliques.pruning_keep_fraction = toDouble(k, v); }},
      {"selection.normal_consistency",
       [](MacParams& p, auto& k, auto& v) { p.selection.normal_consistency = toBool(k, v); }},
      {"selection.normal_consistency_threshold",
       [](MacParams& p, auto& k, auto& v) { p.selection.normal_consistency_threshold = toDouble(k, v); }},
      {"selection.top_k", [](MacParams& p, auto& k, auto& v) { p.selection.top_k = toCount(k, v); }},
      {"hypotheses.weighting",
       [](MacParams& p, const std::string& k, const std::string& v) {
         p.hypotheses.weighting = toEnum<HypothesisWeighting>(
             k, v,
             {{"equal", HypothesisWeighting::kEqual}, {"eigenvector", HypothesisWeighting::kEigenvector}});
       }},
      {"evaluation.metric",
       [](MacParams& p, const std::string& k, const std::string& v) {
         p.evaluation.metric = toEnum<ScoreMetric>(k, v,
                                                   {{"mae", ScoreMetric::kMAE},
                                                    {"mse", ScoreMetric::kMSE},
                                                    {"inlier_count", ScoreMetric::kInlierCount}});
       }},
      {"evaluation.inlier_threshold",
       [](MacParams& p, auto& k, auto& v) { p.evaluation.inlier_threshold = toDouble(k, v); }},
      {"evaluation.min_inliers",
       [](MacParams& p, auto& k, auto& v) { p.evaluation.min_inliers = toCount(k, v); }},
      {"refinement.enabled", [](MacParams& p, auto& k, auto& v) { p.refinement.enabled = toBool(k, v); }},
      {"refinement.max_iterations",
       [](MacParams& p, auto& k, auto& v) { p.refinement.max_iterations = int(toDouble(k, v)); }},
      {"num_threads", [](MacParams& p, auto& k, auto& v) { p.num_threads = int(toDouble(k, v)); }},
  };
  return table;
}

using FeatureSetter = std::function<void(FeatureParams&, const std::string& key, const std::string& value)>;

const std::map<std::string, FeatureSetter>& featureSetters() {
  static const std::map<std::string, FeatureSetter> table = {
      {"features.voxel_size", [](FeatureParams& p, auto& k, auto& v) { p.voxel_size = toDouble(k, v); }},
      {"features.normal_radius_factor",
       [](FeatureParams& p, auto& k, auto& v) { p.normal_radius_factor = toDouble(k, v); }},
      {"features.feature_radius_factor",
       [](FeatureParams& p, auto& k, auto& v) { p.feature_radius_factor = toDouble(k, v); }},
      {"features.max_correspondences",
       [](FeatureParams& p, auto& k, auto& v) { p.max_correspondences = toCount(k, v); }},
      {"features.mutual_filter", [](FeatureParams& p, auto& k, auto& v) { p.mutual_filter = toBool(k, v); }},
      {"features.ratio_test", [](FeatureParams& p, auto& k, auto& v) { p.ratio_test = toDouble(k, v); }},
      {"features.num_threads",
       [](FeatureParams& p, auto& k, auto& v) { p.num_threads = int(toDouble(k, v)); }},
      {"features.gaussian_sigma_resolutions",
       [](FeatureParams& p, auto& k, auto& v) { p.gaussian_sigma_resolutions = toDouble(k, v); }},
      {"features.resolution_samples",
       [](FeatureParams& p, auto& k, auto& v) { p.resolution_samples = toCount(k, v); }},
  };
  return table;
}

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\"'");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\"'");
  return text.substr(first, last - first + 1);
}

bool isCoreSection(const std::string& section) {
  return section.empty() || section == "graph" || section == "cliques" || section == "selection" ||
         section == "hypotheses" || section == "evaluation" || section == "refinement";
}

}  // namespace

void setParam(MacParams& params, const std::string& key, const std::string& value) {
  const auto it = setters().find(key);
  if (it == setters().end()) throw std::invalid_argument("unknown parameter '" + key + "'");
  it->second(params, key, value);
}

void loadParamsFile(MacParams& params, const std::string& path) {
  readPresetFile(path, [&](const std::string& key, const std::string& value) {
    const auto dot = key.find('.');
    if (isCoreSection(dot == std::string::npos ? "" : key.substr(0, dot))) setParam(params, key, value);
  });
}

bool isFeatureKey(const std::string& key) { return key.rfind("features.", 0) == 0; }

void setFeatureParam(FeatureParams& params, const std::string& key, const std::string& value) {
  const auto it = featureSetters().find(key);
  if (it == featureSetters().end()) throw std::invalid_argument("unknown parameter '" + key + "'");
  it->second(params, key, value);
}

void loadFeatureParamsFile(FeatureParams& params, const std::string& path) {
  readPresetFile(path, [&](const std::string& key, const std::string& value) {
    if (isFeatureKey(key)) setFeatureParam(params, key, value);
  });
}

void applyAssignment(MacParams& params, FeatureParams& features, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument("--set expects KEY=VALUE, got '" + assignment + "'");
  const std::string key = assignment.substr(0, eq), value = assignment.substr(eq + 1);
  if (isFeatureKey(key))
    setFeatureParam(features, key, value);
  else
    setParam(params, key, value);
}

void readPresetFile(const std::string& path,
                    const std::function<void(const std::string& key, const std::string& value)>& visit) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open config '" + path + "'");
  std::string line, section;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    if (trim(line).empty()) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos)
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 'key: value'");
    const bool indented = line[0] == ' ' || line[0] == '\t';
    const std::string key = trim(line.substr(0, colon)), value = trim(line.substr(colon + 1));
    if (!indented) {
      if (value.empty()) {
        section = key;
        continue;
      }
      section.clear();
    }
    try {
      visit(section.empty() ? key : section + "." + key, value);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": " + e.what());
    }
  }
}

}  // namespace mac_registration
