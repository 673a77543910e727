#include "mac_registration/config/parameter_table.hpp"

#include <map>
#include <sstream>
#include <stdexcept>

#include "table_entries.hpp"

namespace mac_registration {
namespace {

using namespace table_entries;
using Config = RegistrationConfig;
using Range = ParameterRange;

const Names<CompatibilityScore> kScores{
    {{"gaussian", CompatibilityScore::kGaussian}, {"quadratic", CompatibilityScore::kQuadratic}}};
const Names<HypothesisWeighting> kWeightings{
    {{"equal", HypothesisWeighting::kEqual}, {"eigenvector", HypothesisWeighting::kEigenvector}}};
const Names<ScoreMetric> kMetrics{
    {{"mae", ScoreMetric::kMAE}, {"mse", ScoreMetric::kMSE}, {"inlier_count", ScoreMetric::kInlierCount}}};

// The core's numbers: unit and range from its schema (macParameterRanges()), which the core checks alone.
const MacParameterRange& coreRange(const std::string& key) {
  const MacParameterRange* entry = findMacParameterRange(key);
  if (!entry) throw std::logic_error("the core's parameter schema has no '" + key + "'");
  return *entry;
}

template <typename Field>
Parameter real(std::string key, Field field, std::string doc) {
  const MacParameterRange& core = coreRange(key);
  return table_entries::real<Config>(std::move(key), field, core.unit, core.range, std::move(doc));
}

template <typename Field>
Parameter integer(std::string key, Field field, std::string doc) {
  const MacParameterRange& core = coreRange(key);
  return table_entries::integer<Config>(std::move(key), field, core.unit, core.range, std::move(doc));
}

template <typename Field>
Parameter count(std::string key, Field field, std::string doc) {
  const MacParameterRange& core = coreRange(key);
  return table_entries::count<Config>(std::move(key), field, core.unit, core.range, std::move(doc));
}

// The front end's numbers, whose ranges are written here.
template <typename Field>
Parameter real(std::string key, Field field, std::string unit, ParameterRange range, std::string doc) {
  return table_entries::real<Config>(std::move(key), field, std::move(unit), std::move(range),
                                     std::move(doc));
}

template <typename Field>
Parameter count(std::string key, Field field, std::string unit, ParameterRange range, std::string doc) {
  return table_entries::count<Config>(std::move(key), field, std::move(unit), std::move(range),
                                      std::move(doc));
}

template <typename Field>
Parameter boolean(std::string key, Field field, std::string doc) {
  return table_entries::boolean<Config>(std::move(key), field, std::move(doc));
}

template <typename Enum, typename Field>
Parameter choice(std::string key, Field field, const Names<Enum>& names, std::string doc) {
  return table_entries::choice<Config>(std::move(key), field, names, std::move(doc));
}

std::vector<Parameter> makeTable() {
  // A doc says what the parameter does; its range is shown from the entry's range, never repeated in it.
  std::vector<Parameter> table{
      choice("graph.score", MAC_FIELD(mac.graph.score), kScores,
             "compatibility score of the rigidity residual: gaussian (paper Eq. 2) or quadratic"),
      real("graph.gaussian_sigma", MAC_FIELD(mac.graph.gaussian_sigma),
           "d_cmp of the Gaussian score; the paper uses 10 x cloud resolution; auto = 1 x "
           "features.voxel_size"),
      real("graph.quadratic_threshold", MAC_FIELD(mac.graph.quadratic_threshold),
           "tau of the quadratic score; auto = 2 x features.voxel_size"),
      real("graph.t_cmp", MAC_FIELD(mac.graph.t_cmp),
           "edge where the score >= t_cmp; higher = sparser graph"),
      boolean("graph.second_order", MAC_FIELD(mac.graph.second_order),
              "second-order compatibility graph (paper Eq. 4)"),
      count("graph.max_correspondences", MAC_FIELD(mac.graph.max_correspondences),
            "most correspondences the pair test runs on (an even subset above it; all are scored)"),
      count("graph.max_edges", MAC_FIELD(mac.graph.max_edges),
            "memory bound of the first-order graph; denser graphs keep their highest-degree nodes"),
      real("graph.max_second_order_work", MAC_FIELD(mac.graph.max_second_order_work),
           "time bound of the second-order weights (~1 ns each)"),
      real("graph.dense_mean_degree", MAC_FIELD(mac.graph.dense_mean_degree),
           "above this mean degree, edges below Otsu's cut of the weights are pruned"),
      integer("cliques.min_clique_size", MAC_FIELD(mac.cliques.min_clique_size),
              "smallest maximal clique used"),
      integer("cliques.max_clique_size", MAC_FIELD(mac.cliques.max_clique_size),
              "largest clique reported, at least cliques.min_clique_size"),
      count("cliques.max_cliques", MAC_FIELD(mac.cliques.max_cliques),
            "most cliques one search may enumerate; then the graph is pruned and searched again"),
      integer("cliques.max_degeneracy", MAC_FIELD(mac.cliques.max_degeneracy),
              "dense cores are thinned to this many strongest nodes before the search"),
      real("cliques.time_limit", MAC_FIELD(mac.cliques.time_limit),
           "budget of the whole clique search, CPU time of its thread"),
      integer("cliques.max_pruning_rounds", MAC_FIELD(mac.cliques.max_pruning_rounds),
              "pruned re-searches after a bounded search"),
      real("cliques.pruning_keep_fraction", MAC_FIELD(mac.cliques.pruning_keep_fraction),
           "fraction of the nodes each pruning round keeps"),
      boolean("selection.normal_consistency", MAC_FIELD(mac.selection.normal_consistency),
              "normal-consistency filter of the selected cliques (paper Sec. 3.3); needs normals"),
      real("selection.normal_consistency_threshold", MAC_FIELD(mac.selection.normal_consistency_threshold),
           "t_alpha: |sin a_s - sin a_t| must stay below it"),
      count("selection.top_k", MAC_FIELD(mac.selection.top_k), "keep the K heaviest selected cliques"),
      choice("hypotheses.weighting", MAC_FIELD(mac.hypotheses.weighting), kWeightings,
             "equal (instance-equal SVD) or eigenvector (weighted SVD)"),
      choice("evaluation.metric", MAC_FIELD(mac.evaluation.metric), kMetrics,
             "hypothesis score: mae (paper default), mse or inlier_count"),
      real("evaluation.inlier_threshold", MAC_FIELD(mac.evaluation.inlier_threshold),
           "tau: residual below which a correspondence is an inlier; auto = 2 x features.voxel_size"),
      count("evaluation.min_inliers", MAC_FIELD(mac.evaluation.min_inliers), "fewest inliers for a success"),
      real("evaluation.max_tilt_deg", MAC_FIELD(mac.evaluation.max_tilt_deg),
           "largest turn of the source's z axis from the target's a pose may have; 180 = no prior"),
      boolean("refinement.enabled", MAC_FIELD(mac.refinement.enabled), "reweighted-SVD refinement"),
      integer("refinement.max_iterations", MAC_FIELD(mac.refinement.max_iterations),
              "reweighted-SVD rounds at most"),
      boolean("verification.enabled", MAC_FIELD(mac.verification.enabled),
              "verify each transform (rivals, and with clouds their alignment) before calling it a success"),
      real("verification.min_confidence", MAC_FIELD(mac.verification.min_confidence),
           "fewest confidence for a success; BENCHMARKS.md lists the measured error rates at each value"),
      boolean("verification.fine_alignment", MAC_FIELD(mac.verification.fine_alignment),
              "with clouds: align the pose finely on them (point-to-plane ICP), weigh the move, report the "
              "fine pose"),
      real("verification.distinct_pose_factor", MAC_FIELD(mac.verification.distinct_pose_factor),
           "a rival pose moves the source points more than this many tau (RMS) from the reported one"),
      count("verification.max_alternatives", MAC_FIELD(mac.verification.max_alternatives),
            "distinct competing poses reported with the result"),
      real("features.voxel_size", MAC_FIELD(features.voxel_size), "m",
           Range::above(0).orAuto("the leaf that leaves about 5000 keypoints in a cloud"),
           "voxel grid leaf: the keypoint spacing and the unit of the radii"),
      real("features.normal_radius_factor", MAC_FIELD(features.normal_radius_factor), "x voxel_size",
           Range::above(0), "normal estimation radius"),
      real("features.feature_radius_factor", MAC_FIELD(features.feature_radius_factor), "x voxel_size",
           Range::above(0), "FPFH radius, wider than features.normal_radius_factor"),
      count("features.min_feature_neighbours", MAC_FIELD(features.min_feature_neighbours), "keypoints",
            Range::atLeast(0).withZeroMeaning("the radii as given"),
            "fewest keypoints in the median keypoint's FPFH sphere: both radii grow for sparser clouds"),
      real("features.support_voxel_factor", MAC_FIELD(features.support_voxel_factor), "x voxel_size",
           Range::atLeast(1).withHint(
               "1 = the keypoints themselves; above 1, < features.feature_radius_factor"),
           "leaf of the keypoint grid FPFH sums over; 1 = the keypoints"),
      count("features.max_correspondences", MAC_FIELD(features.max_correspondences), "correspondences",
            Range::atLeast(3), "matches kept, closest in feature space first"),
      boolean("features.mutual_filter", MAC_FIELD(features.mutual_filter),
              "keep only mutual nearest neighbours in feature space"),
      real("features.ratio_test", MAC_FIELD(features.ratio_test), "", Range::open(0, 1).orOff("off"),
           "Lowe's ratio of nearest to second-nearest distance"),
      real("features.match_epsilon", MAC_FIELD(features.match_epsilon), "",
           Range::atLeast(0).withZeroMeaning("exact"),
           "descriptor search approximation: a match at most (1 + it) x the nearest distance"),
      real("features.gaussian_sigma_resolutions", MAC_FIELD(features.gaussian_sigma_resolutions),
           "x resolution", Range::above(0).orOff("use graph.gaussian_sigma in metres"),
           "d_cmp in cloud resolutions (paper: 10)"),
      count("features.resolution_samples", MAC_FIELD(features.resolution_samples), "points",
            Range::atLeast(100), "query points the cloud resolution is estimated from"),
      real("relocalization.place_spacing", MAC_FIELD(relocalization.place_spacing), "m",
           Range::above(0).orAuto("10 x features.voxel_size"),
           "spacing of the map's candidate places (a grid in the map's x-y plane)"),
      count("relocalization.max_candidates", MAC_FIELD(relocalization.max_candidates), "places",
            Range::closed(1, 20),
            "best-ranked places MAC and the verification run on; beyond 3 a location needs the odds of "
            "verification.min_confidence times places / 3"),
      real("relocalization.time_limit", MAC_FIELD(relocalization.time_limit), "s", Range::above(0),
           "wall time of a query after its description; no further place starts beyond it"),
      [] {
        // One thread count for every parallel stage, core and front end alike.
        const MacParameterRange& core = coreRange("num_threads");
        Parameter p = facts<Config>("num_threads", ParameterType::kInteger, core.unit, core.range,
                                    "worker threads of the parallel stages; results do not depend on it");
        p.get = [](const Config& c) -> ParameterValue { return (long long)c.mac.num_threads; };
        p.set = [](Config& c, const ParameterValue& v) {
          c.mac.num_threads = c.features.num_threads = static_cast<int>(asInteger(v));
        };
        return p;
      }(),
  };
  // Every range of the core's schema is documented here, so that no core parameter goes unread.
  for (const auto& core : macParameterRanges()) {
    bool listed = false;
    for (const auto& p : table) listed = listed || p.key == core.key;
    if (!listed) throw std::logic_error("the parameter table has no entry for the core's '" + core.key + "'");
  }
  return table;
}

#undef MAC_FIELD

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

}  // namespace

const std::vector<Parameter>& parameterTable() {
  static const std::vector<Parameter> table = makeTable();
  return table;
}

const Parameter* findParameter(const std::string& key) {
  static const std::map<std::string, const Parameter*> index = [] {
    std::map<std::string, const Parameter*> by_key;
    for (const auto& p : parameterTable()) by_key[p.key] = &p;
    return by_key;
  }();
  const auto it = index.find(key);
  return it == index.end() ? nullptr : it->second;
}

ParameterValue parseParameterValue(const ParameterInfo& parameter, const std::string& raw) {
  const std::string text = trimmed(raw);
  const auto refuse = [&](const std::string& what) {
    return std::invalid_argument(parameter.key + ": '" + text + "' is not " + what);
  };
  if (parameter.range.zero == ParameterRange::Zero::kAuto && text == "auto") return 0.0;
  switch (parameter.type) {
    case ParameterType::kBool:
      if (text == "true" || text == "1") return true;
      if (text == "false" || text == "0") return false;
      throw refuse("true/false");
    case ParameterType::kChoice:
    case ParameterType::kText:
      return text;
    case ParameterType::kReal:
    case ParameterType::kInteger:
    case ParameterType::kCount: {
      try {
        std::size_t used = 0;
        const double v = std::stod(text, &used);
        if (used == text.size()) return v;
      } catch (const std::exception&) {
      }
      throw refuse("a number");
    }
  }
  throw refuse("valid");
}

std::string formatParameterValue(const ParameterValue& value) {
  std::ostringstream text;
  if (const auto* b = std::get_if<bool>(&value)) text << (*b ? "true" : "false");
  if (const auto* i = std::get_if<long long>(&value)) text << *i;
  if (const auto* d = std::get_if<double>(&value)) text << *d;
  if (const auto* s = std::get_if<std::string>(&value)) text << *s;
  return text.str();
}

void setParameter(RegistrationConfig& config, const std::string& key, const ParameterValue& value) {
  const Parameter* parameter = findParameter(key);
  if (!parameter) throw std::invalid_argument("unknown parameter '" + key + "'");
  try {
    parameter->set(config, value);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(key + ": '" + formatParameterValue(value) + "': " + e.what());
  }
}

void setParameter(RegistrationConfig& config, const std::string& key, const std::string& text) {
  const Parameter* parameter = findParameter(key);
  if (!parameter) throw std::invalid_argument("unknown parameter '" + key + "'");
  setParameter(config, key, parseParameterValue(*parameter, text));
}

void applyAssignment(RegistrationConfig& config, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument("--set expects KEY=VALUE, got '" + assignment + "'");
  setParameter(config, assignment.substr(0, eq), assignment.substr(eq + 1));
}

std::string rangeProblem(const ParameterInfo& parameter, const ParameterValue& value) {
  const auto* real = std::get_if<double>(&value);
  const auto* whole = std::get_if<long long>(&value);
  if (!real && !whole) return "";
  const double number = real ? *real : double(*whole);
  if (parameter.range.contains(number)) return "";
  return outOfRangeMessage(parameter.key, number, parameter.unit, parameter.range);
}

std::string describeParameter(const ParameterInfo& parameter, const ParameterValue& value) {
  const auto* number = std::get_if<double>(&value);
  const bool automatic = parameter.range.zero == ParameterRange::Zero::kAuto && number && *number == 0.0;
  std::string text = parameter.key + " = " + (automatic ? std::string("auto") : formatParameterValue(value));
  if (!parameter.unit.empty()) text += " [" + parameter.unit + "]";
  return text;
}

std::vector<std::string> validateConfig(const RegistrationConfig& config) {
  std::vector<std::string> problems = validateParams(config.mac, AutoValues::kAccepted);
  for (auto& p : validateFeatureParams(config.features)) problems.push_back(std::move(p));
  for (auto& p : validateRelocalizationParams(config.relocalization)) problems.push_back(std::move(p));
  return problems;
}

std::string describeConfig(const RegistrationConfig& config) {
  std::string text;
  for (const auto& p : parameterTable()) {
    text += (text.empty() ? "  " : "\n  ") + describeParameter(p, p.get(config));
  }
  return text;
}

}  // namespace mac_registration
