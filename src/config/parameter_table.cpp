#include "mac_registration/config/parameter_table.hpp"

#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace mac_registration {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The typed views of a value; each refuses what its type cannot hold.
double asReal(const ParameterValue& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* i = std::get_if<long long>(&v)) return double(*i);
  throw std::invalid_argument("expected a number");
}

long long asInteger(const ParameterValue& v) {
  const double d = asReal(v);
  if (!std::isfinite(d) || d != std::floor(d) || std::fabs(d) > 1e15)
    throw std::invalid_argument("expected a whole number");
  return static_cast<long long>(d);
}

std::size_t asCount(const ParameterValue& v) {
  const long long i = asInteger(v);
  // A negative count would wrap around to a huge size_t and pass every range check.
  if (i < 0) throw std::invalid_argument("expected a count (>= 0)");
  return static_cast<std::size_t>(i);
}

bool asBool(const ParameterValue& v) {
  if (const auto* b = std::get_if<bool>(&v)) return *b;
  throw std::invalid_argument("expected true or false");
}

const std::string& asText(const ParameterValue& v) {
  if (const auto* s = std::get_if<std::string>(&v)) return *s;
  throw std::invalid_argument("expected a name");
}

// An enum field and its names, both ways.
template <typename Enum>
struct Names {
  std::vector<std::pair<std::string, Enum>> pairs;

  Enum parse(const ParameterValue& v) const {
    const std::string& text = asText(v);
    for (const auto& [name, value] : pairs) {
      if (name == text) return value;
    }
    throw std::invalid_argument("'" + text + "' is not one of " + list());
  }
  std::string name(Enum value) const {
    for (const auto& [n, e] : pairs) {
      if (e == value) return n;
    }
    return "?";
  }
  std::vector<std::string> all() const {
    std::vector<std::string> names;
    for (const auto& pair : pairs) names.push_back(pair.first);
    return names;
  }
  std::string list() const {
    std::string text;
    for (const auto& n : all()) text += (text.empty() ? "" : ", ") + n;
    return text;
  }
};

const Names<CompatibilityScore> kScores{
    {{"gaussian", CompatibilityScore::kGaussian}, {"quadratic", CompatibilityScore::kQuadratic}}};
const Names<HypothesisWeighting> kWeightings{
    {{"equal", HypothesisWeighting::kEqual}, {"eigenvector", HypothesisWeighting::kEigenvector}}};
const Names<ScoreMetric> kMetrics{
    {{"mae", ScoreMetric::kMAE}, {"mse", ScoreMetric::kMSE}, {"inlier_count", ScoreMetric::kInlierCount}}};

// Entry builders: a member pointer gives get and set, so an entry is one line of facts.
using Config = RegistrationConfig;

// The facts of an entry; the builders below add its get and set.
Parameter facts(std::string key, ParameterType type, std::string unit, double min, double max,
                bool zero_means_off, std::string doc) {
  Parameter p;
  p.key = std::move(key);
  p.type = type;
  p.unit = std::move(unit);
  p.min = min;
  p.max = max;
  p.zero_means_off = zero_means_off;
  p.doc = std::move(doc);
  return p;
}

// A number: its field is read as a double (reals) or an integer, and written through `convert` (asReal,
// asInteger or asCount), which refuses what the field's type cannot hold.
template <typename Field, typename Convert>
Parameter numeric(ParameterType type, std::string key, Field field, Convert convert, std::string unit,
                  double min, double max, std::string doc, bool zero_means_off) {
  Parameter p = facts(std::move(key), type, std::move(unit), min, max, zero_means_off, std::move(doc));
  p.get = [field, type](const Config& c) -> ParameterValue {
    if (type == ParameterType::kReal) return double(field(c));
    return static_cast<long long>(field(c));
  };
  p.set = [field, convert](Config& c, const ParameterValue& v) {
    using Value = std::decay_t<decltype(field(c))>;
    field(c) = static_cast<Value>(convert(v));
  };
  return p;
}

template <typename Field>
Parameter real(std::string key, Field field, std::string unit, double min, double max, std::string doc,
               bool zero_means_off = false) {
  return numeric(ParameterType::kReal, std::move(key), field, asReal, std::move(unit), min, max,
                 std::move(doc), zero_means_off);
}

template <typename Field>
Parameter integer(std::string key, Field field, std::string unit, double min, double max, std::string doc,
                  bool zero_means_off = false) {
  return numeric(ParameterType::kInteger, std::move(key), field, asInteger, std::move(unit), min, max,
                 std::move(doc), zero_means_off);
}

template <typename Field>
Parameter count(std::string key, Field field, std::string unit, double min, double max, std::string doc,
                bool zero_means_off = false) {
  return numeric(ParameterType::kCount, std::move(key), field, asCount, std::move(unit), min, max,
                 std::move(doc), zero_means_off);
}

template <typename Field>
Parameter boolean(std::string key, Field field, std::string doc) {
  Parameter p = facts(std::move(key), ParameterType::kBool, "", 0.0, 1.0, false, std::move(doc));
  p.get = [field](const Config& c) -> ParameterValue { return bool(field(c)); };
  p.set = [field](Config& c, const ParameterValue& v) { field(c) = asBool(v); };
  return p;
}

template <typename Enum, typename Field>
Parameter choice(std::string key, Field field, const Names<Enum>& names, std::string doc) {
  Parameter p = facts(std::move(key), ParameterType::kChoice, "", 0.0, 0.0, false, std::move(doc));
  p.choices = names.all();
  p.get = [field, &names](const Config& c) -> ParameterValue { return names.name(field(c)); };
  p.set = [field, &names](Config& c, const ParameterValue& v) { field(c) = names.parse(v); };
  return p;
}

// A real whose 0 may be written "auto" (a value the registration derives from the data).
Parameter autoDerived(Parameter p) {
  p.zero_means_auto = true;
  auto set = p.set;
  p.set = [set](Config& c, const ParameterValue& v) {
    const auto* text = std::get_if<std::string>(&v);
    set(c, text && *text == "auto" ? ParameterValue(0.0) : v);
  };
  return p;
}

// A generic accessor: the same lambda reads a const config and writes a mutable one.
#define MAC_FIELD(path) \
  [](auto& c) -> auto& { return c.path; }

std::vector<Parameter> makeTable() {
  return {
      choice("graph.score", MAC_FIELD(mac.graph.score), kScores,
             "compatibility score of the rigidity residual: gaussian (paper Eq. 2) or quadratic"),
      autoDerived(real("graph.gaussian_sigma", MAC_FIELD(mac.graph.gaussian_sigma), "m", 0.0, kInf,
                       "d_cmp of the Gaussian score; the paper uses 10 x cloud resolution")),
      autoDerived(real("graph.quadratic_threshold", MAC_FIELD(mac.graph.quadratic_threshold), "m", 0.0, kInf,
                       "tau of the quadratic score; auto = 2 x features.voxel_size")),
      real("graph.t_cmp", MAC_FIELD(mac.graph.t_cmp), "", 0.0, 1.0,
           "edge where the score >= t_cmp (open interval); higher = sparser graph"),
      boolean("graph.second_order", MAC_FIELD(mac.graph.second_order),
              "second-order compatibility graph (paper Eq. 4)"),
      count("graph.max_correspondences", MAC_FIELD(mac.graph.max_correspondences), "correspondences", 1000,
            kInf,
            "most correspondences the pair test runs on (an even subset above it; all are scored), 0 = all",
            true),
      count("graph.max_edges", MAC_FIELD(mac.graph.max_edges), "edges", 1000, kInf,
            "memory bound of the first-order graph; denser graphs keep their highest-degree nodes"),
      real("graph.max_second_order_work", MAC_FIELD(mac.graph.max_second_order_work), "multiply-adds", 1e5,
           kInf, "time bound of the second-order weights (~1 ns each)"),
      real("graph.dense_mean_degree", MAC_FIELD(mac.graph.dense_mean_degree), "degree", 1.0, kInf,
           "above this mean degree, edges below Otsu's cut of the weights are pruned; 0 = never", true),
      integer("cliques.min_clique_size", MAC_FIELD(mac.cliques.min_clique_size), "nodes", 3, kInf,
              "smallest maximal clique used"),
      integer("cliques.max_clique_size", MAC_FIELD(mac.cliques.max_clique_size), "nodes", 3, kInf,
              "largest clique reported, 0 = no cap (else >= cliques.min_clique_size)", true),
      count("cliques.max_cliques", MAC_FIELD(mac.cliques.max_cliques), "cliques", 1, kInf,
            "most cliques one search may enumerate; then the graph is pruned and searched again"),
      integer("cliques.max_degeneracy", MAC_FIELD(mac.cliques.max_degeneracy), "core number", 2, kInf,
              "dense cores are thinned to this many strongest nodes before the search, 0 = no bound", true),
      real("cliques.time_limit", MAC_FIELD(mac.cliques.time_limit), "s", 0.0, kInf,
           "budget of the whole clique search (> 0), CPU time of its thread"),
      integer("cliques.max_pruning_rounds", MAC_FIELD(mac.cliques.max_pruning_rounds), "rounds", 0, 10,
              "pruned re-searches after a bounded search"),
      real("cliques.pruning_keep_fraction", MAC_FIELD(mac.cliques.pruning_keep_fraction), "", 0.0, 1.0,
           "fraction of the nodes each pruning round keeps (open interval)"),
      boolean("selection.normal_consistency", MAC_FIELD(mac.selection.normal_consistency),
              "normal-consistency filter of the selected cliques (paper Sec. 3.3); needs normals"),
      real("selection.normal_consistency_threshold", MAC_FIELD(mac.selection.normal_consistency_threshold),
           "", 0.0, 1.0, "t_alpha: |sin a_s - sin a_t| must stay below it (in (0, 1])"),
      count("selection.top_k", MAC_FIELD(mac.selection.top_k), "cliques", 1, kInf,
            "keep the K heaviest selected cliques, 0 = all", true),
      choice("hypotheses.weighting", MAC_FIELD(mac.hypotheses.weighting), kWeightings,
             "equal (instance-equal SVD) or eigenvector (weighted SVD)"),
      choice("evaluation.metric", MAC_FIELD(mac.evaluation.metric), kMetrics,
             "hypothesis score: mae (paper default), mse or inlier_count"),
      autoDerived(real(
          "evaluation.inlier_threshold", MAC_FIELD(mac.evaluation.inlier_threshold), "m", 0.0, kInf,
          "tau: residual below which a correspondence is an inlier (> 0); auto = 2 x features.voxel_size")),
      count("evaluation.min_inliers", MAC_FIELD(mac.evaluation.min_inliers), "correspondences", 3, kInf,
            "fewest inliers for a success"),
      boolean("refinement.enabled", MAC_FIELD(mac.refinement.enabled), "reweighted-SVD refinement"),
      integer("refinement.max_iterations", MAC_FIELD(mac.refinement.max_iterations), "rounds", 1, 100,
              "reweighted-SVD rounds at most"),
      boolean("verification.enabled", MAC_FIELD(mac.verification.enabled),
              "verify each transform (rivals, and with clouds their alignment) before calling it a success"),
      real("verification.min_confidence", MAC_FIELD(mac.verification.min_confidence), "", 0.0, 1.0,
           "fewest confidence for a success; BENCHMARKS.md lists the measured error rates at each value"),
      real("verification.distinct_pose_factor", MAC_FIELD(mac.verification.distinct_pose_factor),
           "x inlier_threshold", 0.0, kInf,
           "a rival pose moves the source points more than this many tau (RMS) from the reported one (> 0)"),
      count("verification.max_alternatives", MAC_FIELD(mac.verification.max_alternatives), "poses", 0, 10,
            "distinct competing poses reported with the result"),
      autoDerived(real("features.voxel_size", MAC_FIELD(features.voxel_size), "m", 0.0, kInf,
                       "voxel grid leaf: the keypoint spacing and the unit of the radii (> 0); auto = the "
                       "leaf that leaves "
                       "about 5000 keypoints")),
      real("features.normal_radius_factor", MAC_FIELD(features.normal_radius_factor), "x voxel_size", 0.0,
           kInf, "normal estimation radius (> 0)"),
      real("features.feature_radius_factor", MAC_FIELD(features.feature_radius_factor), "x voxel_size", 0.0,
           kInf, "FPFH radius (> features.normal_radius_factor)"),
      real("features.support_voxel_factor", MAC_FIELD(features.support_voxel_factor), "x voxel_size", 1.0,
           kInf,
           "leaf of the keypoint grid FPFH sums over; 1 = the keypoints (< features.feature_radius_factor)"),
      count("features.max_correspondences", MAC_FIELD(features.max_correspondences), "correspondences", 3,
            kInf, "matches kept, closest in feature space first"),
      boolean("features.mutual_filter", MAC_FIELD(features.mutual_filter),
              "keep only mutual nearest neighbours in feature space"),
      real("features.ratio_test", MAC_FIELD(features.ratio_test), "", 0.0, 1.0,
           "Lowe's ratio of nearest to second-nearest distance (open interval), 0 = off", true),
      real("features.match_epsilon", MAC_FIELD(features.match_epsilon), "", 0.0, kInf,
           "descriptor search approximation: a match at most (1 + it) x the nearest distance, 0 = exact"),
      real("features.gaussian_sigma_resolutions", MAC_FIELD(features.gaussian_sigma_resolutions),
           "x resolution", 0.0, kInf,
           "d_cmp in cloud resolutions (paper: 10), 0 = use graph.gaussian_sigma in metres", true),
      count("features.resolution_samples", MAC_FIELD(features.resolution_samples), "points", 100, kInf,
            "query points the cloud resolution is estimated from"),
      [] {
        // One thread count for every parallel stage, core and front end alike.
        Parameter p =
            facts("num_threads", ParameterType::kInteger, "threads", 0, kInf, true,
                  "worker threads of the parallel stages, 0 = OpenMP's default; results do not depend on it");
        p.get = [](const Config& c) -> ParameterValue { return (long long)c.mac.num_threads; };
        p.set = [](Config& c, const ParameterValue& v) {
          c.mac.num_threads = c.features.num_threads = static_cast<int>(asInteger(v));
        };
        return p;
      }(),
  };
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

ParameterValue parseParameterValue(const Parameter& parameter, const std::string& raw) {
  const std::string text = trimmed(raw);
  const auto refuse = [&](const std::string& what) {
    return std::invalid_argument(parameter.key + ": '" + text + "' is not " + what);
  };
  if (parameter.zero_means_auto && text == "auto") return 0.0;
  switch (parameter.type) {
    case ParameterType::kBool:
      if (text == "true" || text == "1") return true;
      if (text == "false" || text == "0") return false;
      throw refuse("true/false");
    case ParameterType::kChoice:
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

std::vector<std::string> validateConfig(const RegistrationConfig& config) {
  // An auto distance stands for a positive one here; its own range is >= 0.
  MacParams mac = config.mac;
  for (double* distance :
       {&mac.graph.gaussian_sigma, &mac.graph.quadratic_threshold, &mac.evaluation.inlier_threshold}) {
    if (*distance == 0.0) *distance = 1.0;
  }
  std::vector<std::string> problems = validateParams(mac);
  for (auto& p : validateFeatureParams(config.features)) problems.push_back(std::move(p));
  return problems;
}

std::string describeConfig(const RegistrationConfig& config) {
  std::ostringstream text;
  for (const auto& p : parameterTable()) {
    const ParameterValue value = p.get(config);
    const bool automatic = p.zero_means_auto && std::get<double>(value) == 0.0;
    text << (text.tellp() > 0 ? "\n" : "") << "  " << p.key << " = "
         << (automatic ? std::string("auto") : formatParameterValue(value));
    if (!p.unit.empty()) text << " [" << p.unit << "]";
  }
  return text.str();
}

}  // namespace mac_registration
