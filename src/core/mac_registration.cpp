#include "mac_registration/core/mac_registration.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "clique_search.hpp"
#include "clique_selection.hpp"
#include "compatibility_graph.hpp"
#include "evaluation.hpp"
#include "graph_bounds.hpp"
#include "hypotheses.hpp"
#include "refinement.hpp"
#include "verification.hpp"

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

// The bounds that cut a clique search off, with their values: "cliques.time_limit = 2 s (of its own CPU
// time)" and / or "cliques.max_cliques = 200000".
std::string boundsHit(const CliqueSearchStats& stats, const CliqueSearchParams& params) {
  std::ostringstream text;
  if (stats.hit_time_limit)
    text << "cliques.time_limit = " << params.time_limit << " s (of its own CPU time)";
  if (stats.hit_time_limit && stats.hit_count_limit) text << " and ";
  if (stats.hit_count_limit) text << "cliques.max_cliques = " << params.max_cliques;
  return text.str();
}

// Why no clique came out of the search and selection: the data (no compatible triple, or none passed the
// normal-consistency filter) or a bound that cut the search off before it found one, which a larger
// budget may fix and which says nothing about the data.
std::string noCliqueMessage(const MacResult& result, const CliqueSearchStats& stats,
                            const MacParams& params) {
  const std::string size = std::to_string(params.cliques.min_clique_size);
  if (result.counters.cliques > 0) {
    return std::to_string(result.counters.cliques) + " cliques of " + size +
           " or more compatible correspondences found, none passed the normal-consistency filter "
           "(selection.normal_consistency_threshold)";
  }
  if (stats.hit_time_limit || stats.hit_count_limit) {
    return "the clique search hit " + boundsHit(stats, params.cliques) + " before finding a clique of " +
           size + " or more compatible correspondences (after " + std::to_string(stats.pruning_rounds) +
           " pruning rounds); raise cliques.time_limit, or bound the graph (graph.max_correspondences, "
           "graph.max_edges, cliques.max_degeneracy)";
  }
  return "no clique of " + size + " or more compatible correspondences";
}

// With a second thread the selection runs beside the search (igraph's enumeration is serial): the same
// selection, and the search's time is no longer the sum of both. When it selects nothing, `why_none` says
// why.
std::vector<SelectedClique> selectCliques(const CompatibilityGraph& graph, const CorrespondenceSet& c,
                                          const MacParams& params, int threads, const StopFlag* stop,
                                          MacResult& result, std::string& why_none) {
  StreamedSelection selection(graph, threads > 1);
  const auto search_start = Clock::now();
  const CliqueSearchStats stats = searchMaximalCliques(
      graph, params.cliques, [&](const int* nodes, std::size_t size) { selection.add(nodes, size); }, stop);
  selection.finish();
  const double selecting_ms = selection.waitedMilliseconds();
  result.times.clique_wait_ms = stats.igraph_wait_ms;
  result.times.clique_search_ms = millisecondsSince(search_start) - selecting_ms - stats.igraph_wait_ms;
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
  // A pruned search that completed enumerated the cliques of part of the graph only.
  const bool bounded = stats.hit_time_limit || stats.hit_count_limit;
  result.clique_search_complete = stats.complete && !bounded;
  if (stats.stale_igraph_cleanups > 0) {
    result.warnings.push_back("igraph left " + std::to_string(stats.stale_igraph_cleanups) +
                              " temporaries on its cleanup stack after the clique search; dropped them "
                              "unfreed so that no later igraph call frees them");
  }
  if (!stats.error.empty()) throw std::runtime_error("maximal clique search failed: " + stats.error);
  if (stats.cancelled) return {};
  if (bounded && stats.cliques > 0) {  // with none, the failure's message says it
    // Said whether or not a pruned search completed after it: the result is not that of the whole search.
    result.warnings.push_back("clique search stopped by " + boundsHit(stats, params.cliques) + " after " +
                              std::to_string(stats.cliques) + " cliques and " +
                              std::to_string(stats.pruning_rounds) + " pruning rounds" +
                              (stats.complete ? " (the last, on the strongest nodes, complete)" : "") +
                              "; hypotheses come from the cliques found");
  }
  std::vector<SelectedClique> cliques = selection.selector().selected();
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
  if (cliques.empty()) why_none = noCliqueMessage(result, stats, params);
  result.times.selection_ms = selecting_ms + millisecondsSince(filter_start);
  return cliques;
}

struct BestHypothesis {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  HypothesisScore score;
  bool found = false;
  // Every non-degenerate hypothesis, for the verification: those beyond the tilt prior too, since a
  // correspondence set that also supports impossible poses as strongly is no evidence for its answer.
  std::vector<ScoredHypothesis> scored;
};

// Stops early, with a partial result the caller drops, when `stop` is raised. A hypothesis beyond the
// tilt prior is never chosen: the prior says no such pose is possible.
BestHypothesis bestOfCliques(const std::vector<SelectedClique>& cliques, const CorrespondenceSet& c,
                             const std::vector<double>& weights, const HypothesisEvaluator& evaluator,
                             const EvaluationParams& params, int threads, const StopFlag* stop,
                             MacResult& result) {
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
    if (transforms[h]) best.scored.push_back({*transforms[h], scores[h]});
  }
  for (int h = 0; h < count; ++h) {
    if (!transforms[h]) {
      ++result.counters.degenerate_cliques;
    } else if (!withinTilt(*transforms[h], params)) {
      ++result.counters.tilted_hypotheses;
    } else {
      ++result.counters.hypotheses;
      continue;
    }
    scores[h].score = -std::numeric_limits<double>::infinity();  // never chosen over a possible hypothesis
  }
  const int chosen = bestHypothesis(scores);  // the earliest among equals, whatever the thread count
  if (chosen >= 0 && transforms[chosen] && std::isfinite(scores[chosen].score))
    best = {*transforms[chosen], scores[chosen], true, std::move(best.scored)};
  result.times.evaluation_ms = millisecondsSince(start);
  return best;
}

std::string noHypothesisMessage(bool found, const RegistrationCounters& counters) {
  if (found) return "no hypothesis has an inlier within evaluation.inlier_threshold";
  if (counters.tilted_hypotheses == 0)
    return "every selected clique is degenerate (coincident or collinear points)";
  return "no hypothesis within evaluation.max_tilt_deg: " + std::to_string(counters.tilted_hypotheses) +
         " tilt the source beyond it, " + std::to_string(counters.degenerate_cliques) + " are degenerate";
}

// Stage 0: parameters and input. False, with the result failed, when there is nothing to register.
bool checkInput(const CorrespondenceSet& input, const MacParams& params, SanitizedCorrespondences& sane,
                MacResult& result) {
  const auto problems = validateParams(params);
  if (!problems.empty()) {
    std::string message = "invalid parameters:";
    for (const auto& p : problems) message += " " + p;
    fail(result, RegistrationStatus::kInvalidParameters, message);
    return false;
  }
  result.counters.correspondences = input.size();
  try {
    sane = sanitizeCorrespondences(input);
  } catch (const std::invalid_argument& e) {
    fail(result, RegistrationStatus::kInvalidInput, e.what());
    return false;
  }
  result.counters.dropped_non_finite = sane.dropped_non_finite;
  if (sane.dropped_non_finite > 0) {
    result.warnings.push_back("dropped " + std::to_string(sane.dropped_non_finite) +
                              " correspondences with NaN/Inf coordinates");
  }
  if (sane.correspondences.size() < 3) {
    fail(result, RegistrationStatus::kTooFewCorrespondences,
         "need at least 3 finite correspondences, got " + std::to_string(sane.correspondences.size()));
    return false;
  }
  return true;
}

// Stage 1: the first-order graph, as the rows of its pass, with what its bounds did.
FirstOrderRows firstOrderStage(const CorrespondenceSet& c, const MacParams& params, int threads,
                               const StopFlag* stop, MacResult& result) {
  const auto start = Clock::now();
  const double second_order_budget = params.graph.second_order ? params.graph.max_second_order_work : 0.0;
  FirstOrderRows fog = firstOrderRows(c, params.graph, threads, stop, second_order_budget);
  result.counters.graph_nodes = fog.reduced ? fog.reduced_to : fog.sampled ? fog.sampled_to : c.size();
  result.counters.first_order_edges = fog.rows.numEdges();
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
  if (fog.second_order_bounded) {
    result.graph_reduced = true;
    result.counters.graph_nodes = fog.second_order_kept_nodes;
    result.warnings.push_back(
        "graph too dense for the second-order budget (graph.max_second_order_work): kept the " +
        std::to_string(fog.second_order_kept_nodes) + " correspondences of highest degree");
  }
  result.times.graph_ms = millisecondsSince(start);
  return fog;
}

// Stage 2: the second-order weights (their budget came with the first-order graph), then the pruning of a
// dense graph's weak edges.
CompatibilityGraph secondOrderStage(const FirstOrderRows& fog, const MacParams& params, int threads,
                                    const StopFlag* stop, MacResult& result) {
  const auto start = Clock::now();
  BoundedGraph pruned;
  if (params.graph.second_order) {
    pruned = prunedSecondOrderGraph(fog.rows, params.graph.dense_mean_degree, threads, stop).pruned;
  } else {
    pruned = pruneDenseGraph(graphOfRows(fog.rows, threads), params.graph.dense_mean_degree);
  }
  result.counters.pruned_weak_edges = pruned.removed_edges;
  result.counters.graph_edges = pruned.graph.numEdges();
  result.times.second_order_ms = millisecondsSince(start);
  return std::move(pruned.graph);
}

// Stage 7 and the result: refinement of the best hypothesis, its inliers, and the success test.
void refineAndAccept(const BestHypothesis& best, const SanitizedCorrespondences& sane,
                     const HypothesisEvaluator& evaluator, const MacParams& params, const StopFlag* stop,
                     MacResult& result) {
  const auto start = Clock::now();
  RefinementOutcome refined{best.transform, best.score, 0, 0};
  if (params.refinement.enabled) {
    refined = refineTransform(best.transform, best.score, sane.correspondences, evaluator, params.evaluation,
                              params.refinement, stop);
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
  text << result.counters.inliers << " inliers of " << sane.correspondences.size()
       << " correspondences, score " << result.score;
  result.message = text.str();
}

// The stages in order; each failure ends the registration with its reason, a raised stop flag between
// any two of them.
void runPipeline(const CorrespondenceSet& input, const MacParams& params, const StopFlag* stop,
                 const PoseWitness* witness, MacResult& result) {
  SanitizedCorrespondences sane;
  if (!checkInput(input, params, sane, result)) return;
  const CorrespondenceSet& c = sane.correspondences;
  const int threads = params.num_threads > 0 ? params.num_threads : omp_get_max_threads();
  if (stopped(stop, result, "the start")) return;

  CompatibilityGraph graph;
  {
    const FirstOrderRows fog = firstOrderStage(c, params, threads, stop, result);
    if (stopped(stop, result, "the compatibility graph")) return;
    graph = secondOrderStage(fog, params, threads, stop, result);  // the pass's buffers go after it
  }
  if (stopped(stop, result, "the second-order graph")) return;
  if (graph.numEdges() == 0) {
    fail(result, RegistrationStatus::kEmptyGraph,
         params.graph.second_order ? "no compatible triangle of correspondences (empty second-order graph); "
                                     "lower graph.t_cmp or widen the compatibility distance"
                                   : "no compatible pair of correspondences; lower graph.t_cmp or widen the "
                                     "compatibility distance");
    return;
  }

  std::string why_no_clique;
  const std::vector<SelectedClique> cliques =
      selectCliques(graph, c, params, threads, stop, result, why_no_clique);
  if (stopped(stop, result, "the clique search and selection")) return;
  if (cliques.empty()) {
    fail(result, RegistrationStatus::kNoClique, why_no_clique);
    return;
  }

  const std::vector<double> weights = params.hypotheses.weighting == HypothesisWeighting::kEigenvector
                                          ? principalEigenvector(graph, 50, stop)
                                          : std::vector<double>{};
  const HypothesisEvaluator evaluator(c, params.evaluation);
  const BestHypothesis best =
      bestOfCliques(cliques, c, weights, evaluator, params.evaluation, threads, stop, result);
  if (stopped(stop, result, "the hypotheses")) return;
  if (!best.found || !(best.score.score > 0.0)) {
    fail(result, RegistrationStatus::kNoValidHypothesis, noHypothesisMessage(best.found, result.counters));
    return;
  }
  refineAndAccept(best, sane, evaluator, params, stop, result);
  verifyRegistration(c, best.scored, evaluator, params, stop, witness, result);  // judges successes only
}

}  // namespace

MacResult registerCorrespondences(const CorrespondenceSet& correspondences, const MacParams& params,
                                  const StopFlag* stop, const PoseWitness* witness) {
  MacResult result;
  const auto start = Clock::now();
  try {
    runPipeline(correspondences, params, stop, witness, result);
  } catch (const std::bad_alloc&) {
    fail(result, RegistrationStatus::kInternalError,
         "out of memory; lower graph.max_edges or cliques.max_cliques");
  } catch (const std::exception& e) {
    fail(result, RegistrationStatus::kInternalError, e.what());
  }
  if (!hasEstimate(result)) result.T_target_source = Eigen::Isometry3d::Identity();
  result.times.total_ms = millisecondsSince(start);
  return result;
}

}  // namespace mac_registration
