#include "mac_registration/core/mac_registration.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "mac_registration/core/clique_search.hpp"
#include "mac_registration/core/clique_selection.hpp"
#include "mac_registration/core/compatibility_graph.hpp"
#include "mac_registration/core/evaluation.hpp"
#include "mac_registration/core/hypotheses.hpp"
#include "mac_registration/core/refinement.hpp"
#include "mac_registration/core/verification.hpp"

namespace mac_registration {
namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

MacResult& fail(MacResult& result, RegistrationStatus status, const std::string& message) {
  result.success = false;
  result.status = status;
  result.message = message;
  return result;
}

// True, with the result marked cancelled, when the caller asked to stop. Checked after every stage: the
// long loops inside the stages read the flag too and end early, leaving a partial result that is dropped
// here.
bool stopped(const StopFlag* stop, MacResult& result, const char* stage) {
  if (!stopRequested(stop)) return false;
  fail(result, RegistrationStatus::kCancelled, std::string("cancelled at ") + stage);
  return true;
}

// Bounds the cost of the SOG weights: a graph whose second-order pass would exceed the budget keeps only
// its highest-degree nodes (inliers of a dense consensus have the highest degree), shrinking until it fits.
CompatibilityGraph boundSecondOrderWork(CompatibilityGraph graph, double budget, const StopFlag* stop,
                                        MacResult& result) {
  if (secondOrderWork(graph) <= budget) return graph;
  std::vector<double> degree(graph.num_nodes);
  std::size_t nodes = 0;
  for (int i = 0; i < graph.num_nodes; ++i) {
    degree[i] = graph.degree(i);
    nodes += graph.degree(i) > 0;
  }
  CompatibilityGraph reduced;
  do {
    nodes = nodes * 7 / 10;
    reduced = keepNodes(graph, strongestNodes(degree, nodes));
  } while (nodes > 3 && !stopRequested(stop) && secondOrderWork(reduced) > budget);
  result.graph_reduced = true;
  result.counters.graph_nodes = nodes;
  result.warnings.push_back(
      "graph too dense for the second-order budget (graph.max_second_order_work): kept the " +
      std::to_string(nodes) + " correspondences of highest degree");
  return reduced;
}

std::vector<SelectedClique> selectCliques(const CompatibilityGraph& graph, const CorrespondenceSet& c,
                                          const MacParams& params, const StopFlag* stop, MacResult& result) {
  NodeGuidedSelector selector(graph);
  Clock::duration selecting{0};
  const auto search_start = Clock::now();
  const CliqueSearchStats stats = searchMaximalCliques(
      graph, params.cliques,
      [&](const int* nodes, std::size_t size) {
        const auto offered = Clock::now();
        selector.offer(nodes, size);
        selecting += Clock::now() - offered;
      },
      stop);
  const double selecting_ms = std::chrono::duration<double, std::milli>(selecting).count();
  result.times.clique_search_ms = millisecondsSince(search_start) - selecting_ms;
  const auto filter_start = Clock::now();
  result.counters.cliques = stats.cliques;
  result.counters.pruning_rounds = stats.pruning_rounds;
  result.counters.degeneracy = stats.degeneracy;
  result.counters.thinned_nodes = stats.thinned_nodes;
  if (stats.thinned_nodes > 0) {
    result.warnings.push_back(
        "graph degeneracy " + std::to_string(stats.degeneracy) +
        " exceeds cliques.max_degeneracy: " + std::to_string(stats.thinned_nodes) +
        " correspondences of its densest cores were left out of the clique search (they are "
        "still scored)");
  }
  result.clique_search_complete = stats.complete;
  if (stats.stale_igraph_cleanups > 0) {
    result.warnings.push_back("igraph left " + std::to_string(stats.stale_igraph_cleanups) +
                              " temporaries on its cleanup stack after the clique search; dropped them "
                              "unfreed so that no later igraph call frees them");
  }
  if (!stats.error.empty()) throw std::runtime_error("maximal clique search failed: " + stats.error);
  if (stats.cancelled) return {};
  if (!stats.complete) {
    std::ostringstream text;
    text << "clique search stopped by its " << (stats.hit_time_limit ? "time limit (cliques.time_limit)" : "")
         << (stats.hit_time_limit && stats.hit_count_limit ? " and " : "")
         << (stats.hit_count_limit ? "count limit (cliques.max_cliques)" : "") << " after " << stats.cliques
         << " cliques and " << stats.pruning_rounds
         << " pruning rounds; hypotheses come from the cliques found";
    result.warnings.push_back(text.str());
  }
  std::vector<SelectedClique> cliques = selector.selected();
  if (params.selection.normal_consistency) {
    if (c.hasNormals()) {
      cliques = normalConsistentCliques(cliques, c, params.selection.normal_consistency_threshold, stop);
    } else {
      result.warnings.push_back(
          "selection.normal_consistency is on but the correspondences carry no normals: skipped");
    }
  }
  cliques = heaviestCliques(std::move(cliques), params.selection.top_k);
  result.counters.selected_cliques = cliques.size();
  result.times.selection_ms = selecting_ms + millisecondsSince(filter_start);
  return cliques;
}

struct BestHypothesis {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  HypothesisScore score;
  bool found = false;
  std::vector<ScoredHypothesis> scored;  // every non-degenerate hypothesis, for the verification
};

// Stops early, with a partial result the caller drops, when `stop` is raised.
BestHypothesis bestOfCliques(const std::vector<SelectedClique>& cliques, const CorrespondenceSet& c,
                             const std::vector<double>& weights, const HypothesisEvaluator& evaluator,
                             int threads, const StopFlag* stop, MacResult& result) {
  auto start = Clock::now();
  const int count = static_cast<int>(cliques.size());
  std::vector<std::optional<Eigen::Isometry3d>> transforms(count);
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads)
  for (int h = 0; h < count; ++h) {
    if (!stopRequested(stop)) transforms[h] = estimateRigidTransform(c, cliques[h].nodes, weights);
  }
  result.times.hypotheses_ms = millisecondsSince(start);

  start = Clock::now();
  std::vector<HypothesisScore> scores(count);
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads)
  for (int h = 0; h < count; ++h) {
    if (transforms[h] && !stopRequested(stop)) scores[h] = evaluator.score(*transforms[h]);
  }
  BestHypothesis best;
  for (int h = 0; h < count; ++h) {
    if (!transforms[h]) {
      ++result.counters.degenerate_cliques;
      continue;
    }
    ++result.counters.hypotheses;
    // Strictly greater: the earliest hypothesis wins ties, whatever the thread count.
    if (!best.found || scores[h].score > best.score.score) {
      best = {*transforms[h], scores[h], true, {}};
    }
  }
  for (int h = 0; h < count; ++h) {
    if (transforms[h]) best.scored.push_back({*transforms[h], scores[h]});
  }
  result.times.evaluation_ms = millisecondsSince(start);
  return best;
}

void runPipeline(const CorrespondenceSet& input, const MacParams& params, const StopFlag* stop,
                 MacResult& result) {
  const auto problems = validateParams(params);
  if (!problems.empty()) {
    std::string message = "invalid parameters:";
    for (const auto& p : problems) message += " " + p;
    fail(result, RegistrationStatus::kInvalidParameters, message);
    return;
  }
  result.counters.correspondences = input.size();
  SanitizedCorrespondences sane;
  try {
    sane = sanitizeCorrespondences(input);
  } catch (const std::invalid_argument& e) {
    fail(result, RegistrationStatus::kInvalidInput, e.what());
    return;
  }
  const CorrespondenceSet& c = sane.correspondences;
  result.counters.dropped_non_finite = sane.dropped_non_finite;
  if (sane.dropped_non_finite > 0) {
    result.warnings.push_back("dropped " + std::to_string(sane.dropped_non_finite) +
                              " correspondences with NaN/Inf coordinates");
  }
  if (c.size() < 3) {
    fail(result, RegistrationStatus::kTooFewCorrespondences,
         "need at least 3 finite correspondences, got " + std::to_string(c.size()));
    return;
  }
  const int threads = params.num_threads > 0 ? params.num_threads : omp_get_max_threads();
  if (stopped(stop, result, "the start")) return;

  auto start = Clock::now();
  FirstOrderGraph fog = buildFirstOrderGraph(c, params.graph, threads, stop);
  if (stopped(stop, result, "the compatibility graph")) return;
  result.counters.graph_nodes = fog.reduced ? fog.reduced_to : fog.sampled ? fog.sampled_to : c.size();
  result.counters.first_order_edges = fog.graph.numEdges();
  if (fog.sampled) {
    result.graph_reduced = true;
    result.warnings.push_back(std::to_string(c.size()) +
                              " correspondences over graph.max_correspondences: the compatibility graph is "
                              "built on " +
                              std::to_string(fog.sampled_to) + " of them, evenly spaced (all are scored)");
  }
  if (fog.reduced) {
    result.graph_reduced = true;
    result.warnings.push_back("compatibility graph over graph.max_edges (" +
                              std::to_string(fog.compatible_pairs) + " compatible pairs): built on the " +
                              std::to_string(fog.reduced_to) + " correspondences of highest degree");
  }
  result.times.graph_ms = millisecondsSince(start);

  start = Clock::now();
  CompatibilityGraph graph = std::move(fog.graph);
  if (params.graph.second_order) {
    graph = boundSecondOrderWork(std::move(graph), params.graph.max_second_order_work, stop, result);
    if (stopped(stop, result, "the second-order bound")) return;
    graph = buildSecondOrderGraph(graph, threads, stop);
    if (stopped(stop, result, "the second-order graph")) return;
  }
  if (params.graph.dense_mean_degree > 0.0 && graph.num_nodes > 0 &&
      2.0 * double(graph.numEdges()) / graph.num_nodes > params.graph.dense_mean_degree) {
    const std::size_t before = graph.numEdges();
    graph = withoutWeakEdges(graph, otsuEdgeThreshold(graph));
    result.counters.pruned_weak_edges = before - graph.numEdges();
  }
  result.counters.graph_edges = graph.numEdges();
  result.times.second_order_ms = millisecondsSince(start);
  if (graph.numEdges() == 0) {
    fail(result, RegistrationStatus::kEmptyGraph,
         params.graph.second_order ? "no compatible triangle of correspondences (empty second-order graph); "
                                     "lower graph.t_cmp or widen the compatibility distance"
                                   : "no compatible pair of correspondences; lower graph.t_cmp or widen the "
                                     "compatibility distance");
    return;
  }

  const std::vector<SelectedClique> cliques = selectCliques(graph, c, params, stop, result);
  if (stopped(stop, result, "the clique search and selection")) return;
  if (cliques.empty()) {
    fail(result, RegistrationStatus::kNoClique,
         "no clique of " + std::to_string(params.cliques.min_clique_size) +
             " or more compatible correspondences");
    return;
  }

  const std::vector<double> weights = params.hypotheses.weighting == HypothesisWeighting::kEigenvector
                                          ? principalEigenvector(graph, 50, stop)
                                          : std::vector<double>{};
  const HypothesisEvaluator evaluator(c, params.evaluation);
  const BestHypothesis best = bestOfCliques(cliques, c, weights, evaluator, threads, stop, result);
  if (stopped(stop, result, "the hypotheses")) return;
  if (!best.found || !(best.score.score > 0.0)) {
    fail(result, RegistrationStatus::kNoValidHypothesis,
         best.found ? "no hypothesis has an inlier within evaluation.inlier_threshold"
                    : "every selected clique is degenerate (coincident or collinear points)");
    return;
  }

  start = Clock::now();
  RefinementOutcome refined{best.transform, best.score, 0, 0};
  if (params.refinement.enabled) {
    refined =
        refineTransform(best.transform, best.score, c, evaluator, params.evaluation, params.refinement, stop);
  }
  if (stopped(stop, result, "the refinement")) return;
  result.counters.refinement_iterations = refined.iterations;
  result.times.refinement_ms = millisecondsSince(start);

  result.T_target_source = refined.T_target_source;
  result.score = refined.score.score;
  for (int i : evaluator.inliers(refined.T_target_source))
    result.inlier_indices.push_back(sane.original_index[i]);
  result.counters.inliers = result.inlier_indices.size();
  if (result.counters.inliers < params.evaluation.min_inliers) {
    fail(
        result, RegistrationStatus::kTooFewInliers,
        "best transform has " + std::to_string(result.counters.inliers) +
            " inliers, fewer than evaluation.min_inliers = " + std::to_string(params.evaluation.min_inliers));
    return;
  }
  result.success = true;
  result.status = RegistrationStatus::kSuccess;
  std::ostringstream text;
  text << result.counters.inliers << " inliers of " << c.size() << " correspondences, score " << result.score;
  result.message = text.str();
  verifyRegistration(c, best.scored, evaluator, params, stop, result);
}

}  // namespace

const char* toString(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kSuccess:
      return "success";
    case RegistrationStatus::kInvalidParameters:
      return "invalid parameters";
    case RegistrationStatus::kInvalidInput:
      return "invalid input";
    case RegistrationStatus::kTooFewCorrespondences:
      return "too few correspondences";
    case RegistrationStatus::kEmptyGraph:
      return "empty compatibility graph";
    case RegistrationStatus::kNoClique:
      return "no clique";
    case RegistrationStatus::kNoValidHypothesis:
      return "no valid hypothesis";
    case RegistrationStatus::kTooFewInliers:
      return "too few inliers";
    case RegistrationStatus::kInternalError:
      return "internal error";
    case RegistrationStatus::kCancelled:
      return "cancelled";
    case RegistrationStatus::kUnverified:
      return "unverified";
  }
  return "unknown";
}

MacResult registerCorrespondences(const CorrespondenceSet& correspondences, const MacParams& params,
                                  const StopFlag* stop) {
  MacResult result;
  const auto start = Clock::now();
  try {
    runPipeline(correspondences, params, stop, result);
  } catch (const std::bad_alloc&) {
    fail(result, RegistrationStatus::kInternalError,
         "out of memory; lower graph.max_edges or cliques.max_cliques");
  } catch (const std::exception& e) {
    fail(result, RegistrationStatus::kInternalError, e.what());
  }
  if (!result.success && result.status != RegistrationStatus::kTooFewInliers &&
      result.status != RegistrationStatus::kUnverified) {
    result.T_target_source = Eigen::Isometry3d::Identity();
  }
  result.times.total_ms = millisecondsSince(start);
  return result;
}

}  // namespace mac_registration
