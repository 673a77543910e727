#include "mac_registration/core/parameters.hpp"

#include <cmath>
#include <map>
#include <sstream>

namespace mac_registration {

ParameterRange ParameterRange::atLeast(double min) {
  ParameterRange r;
  r.min = min;
  return r;
}

ParameterRange ParameterRange::above(double min) {
  ParameterRange r = atLeast(min);
  r.min_open = true;
  return r;
}

ParameterRange ParameterRange::closed(double min, double max) {
  ParameterRange r = atLeast(min);
  r.max = max;
  r.max_open = false;
  return r;
}

ParameterRange ParameterRange::open(double min, double max) {
  ParameterRange r = closed(min, max);
  r.min_open = r.max_open = true;
  return r;
}

ParameterRange ParameterRange::openClosed(double min, double max) {
  ParameterRange r = closed(min, max);
  r.min_open = true;
  return r;
}

ParameterRange ParameterRange::orOff(std::string meaning) const {
  ParameterRange r = *this;
  r.zero = Zero::kOff;
  r.zero_meaning = std::move(meaning);
  return r;
}

ParameterRange ParameterRange::orAuto(std::string meaning) const {
  ParameterRange r = *this;
  r.zero = Zero::kAuto;
  r.zero_meaning = std::move(meaning);
  return r;
}

ParameterRange ParameterRange::withZeroMeaning(std::string meaning) const {
  ParameterRange r = *this;
  r.zero_meaning = std::move(meaning);
  return r;
}

ParameterRange ParameterRange::orInfinity(std::string meaning) const {
  ParameterRange r = *this;
  r.max_open = false;
  r.infinity_meaning = std::move(meaning);
  return r;
}

ParameterRange ParameterRange::withHint(std::string text) const {
  ParameterRange r = *this;
  r.hint = std::move(text);
  return r;
}

bool ParameterRange::contains(double value) const {
  if (std::isnan(value)) return false;
  if (value == 0.0 && zero != Zero::kPlain) return true;
  const bool above_min = min_open ? value > min : value >= min;
  const bool below_max = max_open ? value < max : value <= max;
  return above_min && below_max;
}

std::string ParameterRange::text() const {
  std::ostringstream text;
  if (std::isfinite(min) && std::isfinite(max)) {
    text << "in " << (min_open ? "(" : "[") << min << ", " << max << (max_open ? ")" : "]");
  } else if (std::isfinite(min)) {
    text << (min_open ? "> " : ">= ") << min;
  } else if (std::isfinite(max)) {
    text << (max_open ? "< " : "<= ") << max;
  } else {
    text << "finite";
  }
  if (!zero_meaning.empty()) text << " (0 = " << (zero == Zero::kAuto ? "auto, " : "") << zero_meaning << ")";
  if (!infinity_meaning.empty()) text << " (inf = " << infinity_meaning << ")";
  return text.str();
}

std::string outOfRangeMessage(const std::string& key, double value, const std::string& unit,
                              const ParameterRange& range) {
  std::ostringstream text;
  text << key << " = " << value;
  if (!unit.empty()) text << " [" << unit << "]";
  text << " is out of range: must be " << range.text();
  if (!range.hint.empty()) text << "; " << range.hint;
  text << ".";
  return text.str();
}

namespace {

using Range = ParameterRange;

// An entry of the schema: the field is read as a double whatever its type.
#define MAC_RANGE(key, field, unit, range)                               \
  MacParameterRange {                                                    \
    key, unit, range, [](const MacParams& p) { return double(p.field); } \
  }

std::vector<MacParameterRange> makeRanges() {
  const std::string auto_distance =
      "derived from features.voxel_size, applies to clouds only: give the distance in metres to register "
      "correspondences";
  return {
      MAC_RANGE("graph.gaussian_sigma", graph.gaussian_sigma, "m", Range::above(0).orAuto(auto_distance)),
      MAC_RANGE("graph.quadratic_threshold", graph.quadratic_threshold, "m",
                Range::above(0).orAuto(auto_distance)),
      MAC_RANGE("graph.t_cmp", graph.t_cmp, "",
                Range::open(0, 1).withHint(
                    "0.99 is the paper's default, lower it for few or very noisy correspondences")),
      MAC_RANGE("graph.max_correspondences", graph.max_correspondences, "correspondences",
                Range::atLeast(1000).orOff("no bound")),
      MAC_RANGE("graph.max_edges", graph.max_edges, "edges", Range::atLeast(1000)),
      MAC_RANGE("graph.max_second_order_work", graph.max_second_order_work, "multiply-adds",
                Range::atLeast(1e5).orInfinity("no bound")),
      MAC_RANGE("graph.dense_mean_degree", graph.dense_mean_degree, "degree",
                Range::atLeast(1).orOff("never prune").orInfinity("never prune")),
      MAC_RANGE("cliques.min_clique_size", cliques.min_clique_size, "nodes",
                Range::atLeast(3).withHint("three points are needed for a rigid transform")),
      MAC_RANGE("cliques.max_clique_size", cliques.max_clique_size, "nodes",
                Range::atLeast(3).orOff("no cap")),
      MAC_RANGE("cliques.max_cliques", cliques.max_cliques, "cliques", Range::atLeast(1)),
      MAC_RANGE("cliques.max_degeneracy", cliques.max_degeneracy, "core number",
                Range::atLeast(2).orOff("no bound")),
      MAC_RANGE("cliques.time_limit", cliques.time_limit, "s", Range::above(0)),
      MAC_RANGE("cliques.max_pruning_rounds", cliques.max_pruning_rounds, "rounds", Range::closed(0, 10)),
      MAC_RANGE("cliques.pruning_keep_fraction", cliques.pruning_keep_fraction, "", Range::open(0, 1)),
      MAC_RANGE("selection.normal_consistency_threshold", selection.normal_consistency_threshold, "",
                Range::openClosed(0, 1)),
      MAC_RANGE("selection.top_k", selection.top_k, "cliques", Range::atLeast(1).orOff("all")),
      MAC_RANGE("evaluation.inlier_threshold", evaluation.inlier_threshold, "m",
                Range::above(0).orAuto(auto_distance)),
      MAC_RANGE("evaluation.min_inliers", evaluation.min_inliers, "correspondences", Range::atLeast(3)),
      MAC_RANGE("evaluation.max_tilt_deg", evaluation.max_tilt_deg, "deg", Range::openClosed(0, 180)),
      MAC_RANGE("refinement.max_iterations", refinement.max_iterations, "rounds", Range::closed(1, 100)),
      MAC_RANGE("verification.min_confidence", verification.min_confidence, "", Range::closed(0, 1)),
      MAC_RANGE("verification.distinct_pose_factor", verification.distinct_pose_factor, "x inlier_threshold",
                Range::above(0)),
      MAC_RANGE("verification.max_alternatives", verification.max_alternatives, "poses",
                Range::closed(0, 10)),
      MAC_RANGE("num_threads", num_threads, "threads", Range::atLeast(0).withZeroMeaning("OpenMP's default")),
  };
}

#undef MAC_RANGE

}  // namespace

const std::vector<MacParameterRange>& macParameterRanges() {
  static const std::vector<MacParameterRange> ranges = makeRanges();
  return ranges;
}

const MacParameterRange* findMacParameterRange(const std::string& key) {
  static const std::map<std::string, const MacParameterRange*> index = [] {
    std::map<std::string, const MacParameterRange*> by_key;
    for (const auto& entry : macParameterRanges()) by_key[entry.key] = &entry;
    return by_key;
  }();
  const auto it = index.find(key);
  return it == index.end() ? nullptr : it->second;
}

std::vector<std::string> validateParams(const MacParams& p, AutoValues autos) {
  std::vector<std::string> problems;
  for (const auto& entry : macParameterRanges()) {
    const double value = entry.value(p);
    const bool derived_here = entry.range.zero == ParameterRange::Zero::kAuto && value == 0.0;
    if (!entry.range.contains(value) || (derived_here && autos == AutoValues::kRefused))
      problems.push_back(outOfRangeMessage(entry.key, value, entry.unit, entry.range));
  }
  // Rules between parameters, once each is within its own range: a value out of range is refused once.
  const auto within = [](const char* key, double value) {
    return findMacParameterRange(key)->range.contains(value);
  };
  if (p.cliques.max_clique_size != 0 && within("cliques.max_clique_size", p.cliques.max_clique_size) &&
      p.cliques.max_clique_size < p.cliques.min_clique_size) {
    std::ostringstream text;
    text << "cliques.max_clique_size = " << p.cliques.max_clique_size
         << " is below cliques.min_clique_size = " << p.cliques.min_clique_size
         << ": must be 0 (no cap) or >= cliques.min_clique_size.";
    problems.push_back(text.str());
  }
  return problems;
}

}  // namespace mac_registration
