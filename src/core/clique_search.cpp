#include "mac_registration/core/clique_search.hpp"

#include <igraph.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <vector>

#include "igraph_session.hpp"
#include "mac_registration/core/graph_bounds.hpp"

namespace mac_registration {
namespace {

using Clock = std::chrono::steady_clock;

struct SearchState {
  const CliqueVisitor* visit = nullptr;
  const StopFlag* stop = nullptr;
  std::size_t limit = 0;
  Clock::time_point deadline;
  std::size_t count = 0;
  bool hit_count = false;
  bool hit_time = false;
  bool cancelled = false;
  std::exception_ptr visitor_error;
  std::vector<int> node_of_vertex;  // igraph vertex -> graph node
  std::vector<int> nodes;
};

// Called by igraph for each maximal clique. Exceptions must not unwind through igraph's C frames, so a
// throwing visitor stops the search and its exception is rethrown afterwards.
igraph_error_t onClique(const igraph_vector_int_t* clique, void* arg) {
  auto& state = *static_cast<SearchState*>(arg);
  const auto size = static_cast<std::size_t>(igraph_vector_int_size(clique));
  state.nodes.resize(size);
  for (std::size_t k = 0; k < size; ++k) state.nodes[k] = state.node_of_vertex[VECTOR(*clique)[k]];
  std::sort(state.nodes.begin(), state.nodes.end());
  try {
    (*state.visit)(state.nodes.data(), size);
  } catch (...) {
    state.visitor_error = std::current_exception();
    return IGRAPH_STOP;
  }
  ++state.count;
  if (stopRequested(state.stop)) {
    state.cancelled = true;
    return IGRAPH_STOP;
  }
  if (state.count >= state.limit) {
    state.hit_count = true;
    return IGRAPH_STOP;
  }
  // A clock read costs tens of nanoseconds; every 64th clique keeps the overshoot small and the cost nil.
  if ((state.count & 63u) == 0 && Clock::now() > state.deadline) {
    state.hit_time = true;
    return IGRAPH_STOP;
  }
  return IGRAPH_SUCCESS;
}

struct SearchOutcome {
  std::size_t cliques = 0;
  bool hit_count = false;
  bool hit_time = false;
  bool cancelled = false;
  int stale_cleanups = 0;
  std::string error;
};

// Whether the edge u-v lies in a triangle: the two ascending lists share a node. Stops at the first one,
// which on a dense core comes within a few entries.
bool inTriangle(const CompatibilityGraph& graph, int u, int v) {
  auto a = graph.neighbours.begin() + graph.offsets[u];
  const auto a_end = graph.neighbours.begin() + graph.offsets[u + 1];
  auto b = graph.neighbours.begin() + graph.offsets[v];
  const auto b_end = graph.neighbours.begin() + graph.offsets[v + 1];
  while (a != a_end && b != b_end) {
    if (*a < *b) {
      ++a;
    } else if (*b < *a) {
      ++b;
    } else {
      return true;
    }
  }
  return false;
}

// Copies the graph into igraph and streams its maximal cliques to `state`; returns igraph's code. With
// min_clique_size 3 or more (every valid configuration), only the edges that lie in a triangle, and the
// nodes they join, go to igraph: such a clique is made of those edges alone, and one that is maximal
// stays maximal without the others, so the cliques are the same. igraph's enumeration clears a vector of all
// its vertices for each vertex it starts from, so the nodes left out would make it quadratic for nothing: a
// chance graph after Otsu's cut keeps many edges in no triangle, and a graph reduced or thinned from a
// large set mostly isolated nodes (igraph 0.10: 1.3 s for 100 000 isolated vertices, 16 s for 300 000).
igraph_error_t enumerateCliques(const CompatibilityGraph& graph, const CliqueSearchParams& params,
                                SearchState& state) {
  const bool triangles_only = params.min_clique_size >= 3;
  // Two nodes whose degrees add up to more than the nodes with an edge share a neighbour: a dense
  // consensus needs no list walked.
  int active = 0;
  for (int i = 0; i < graph.num_nodes; ++i) active += graph.degree(i) > 0;
  const auto keep = [&](int i, int j) {
    return !triangles_only || graph.degree(i) + graph.degree(j) > active || inTriangle(graph, i, j);
  };
  std::vector<char> searched(graph.neighbours.size(), 0);
  std::vector<int> vertex_of_node(graph.num_nodes, -1);
  std::size_t edge_count = 0;
  for (int i = 0; i < graph.num_nodes; ++i) {
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) {
      const int j = graph.neighbours[p];
      if (j <= i || !keep(i, j)) continue;
      searched[p] = 1;
      ++edge_count;
      vertex_of_node[i] = vertex_of_node[j] = 0;  // numbered below, in node order
    }
  }
  state.node_of_vertex.clear();
  for (int i = 0; i < graph.num_nodes; ++i) {
    if (vertex_of_node[i] < 0) continue;
    vertex_of_node[i] = static_cast<int>(state.node_of_vertex.size());
    state.node_of_vertex.push_back(i);
  }
  igraph_vector_int_t edges;
  const igraph_error_t init = igraph_vector_int_init(&edges, static_cast<igraph_integer_t>(2 * edge_count));
  if (init != IGRAPH_SUCCESS) return init;
  igraph_integer_t e = 0;
  for (int i = 0; i < graph.num_nodes; ++i) {
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) {
      if (!searched[p]) continue;
      VECTOR(edges)[e++] = vertex_of_node[i];
      VECTOR(edges)[e++] = vertex_of_node[graph.neighbours[p]];
    }
  }
  igraph_t ig;
  const auto vertices = static_cast<igraph_integer_t>(state.node_of_vertex.size());
  const igraph_error_t created = igraph_create(&ig, &edges, vertices, IGRAPH_UNDIRECTED);
  igraph_vector_int_destroy(&edges);
  if (created != IGRAPH_SUCCESS) return created;
  const igraph_error_t code =
      igraph_maximal_cliques_callback(&ig, onClique, &state, params.min_clique_size, params.max_clique_size);
  igraph_destroy(&ig);
  return code;
}

SearchOutcome searchOnce(const CompatibilityGraph& graph, const CliqueSearchParams& params,
                         Clock::time_point deadline, const CliqueVisitor& visit, const StopFlag* stop) {
  SearchOutcome outcome;
  SearchState state;
  state.visit = &visit;
  state.stop = stop;
  state.limit = params.max_cliques;
  state.deadline = deadline;
  IgraphSession session(deadline, stop);
  const igraph_error_t code = enumerateCliques(graph, params, state);
  outcome.stale_cleanups = session.dropStaleCleanups();
  if (state.visitor_error) std::rethrow_exception(state.visitor_error);

  outcome.cliques = state.count;
  outcome.hit_count = state.hit_count;
  outcome.cancelled = state.cancelled || (code == IGRAPH_INTERRUPTED && stopRequested(stop));
  outcome.hit_time = state.hit_time || (code == IGRAPH_INTERRUPTED && !outcome.cancelled);
  if (code != IGRAPH_SUCCESS && code != IGRAPH_STOP && code != IGRAPH_INTERRUPTED)
    outcome.error = session.lastError();
  return outcome;
}

std::size_t nonIsolatedNodes(const CompatibilityGraph& graph) {
  std::size_t count = 0;
  for (int i = 0; i < graph.num_nodes; ++i) count += graph.degree(i) > 0;
  return count;
}

}  // namespace

CliqueSearchStats searchMaximalCliques(const CompatibilityGraph& graph, const CliqueSearchParams& params,
                                       const CliqueVisitor& visit, const StopFlag* stop) {
  CliqueSearchStats stats;
  const auto start = Clock::now();
  const auto budget =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(params.time_limit));
  const auto final_deadline = start + budget;

  const std::vector<int> core = coreNumbers(graph);
  stats.degeneracy = core.empty() ? 0 : *std::max_element(core.begin(), core.end());
  CompatibilityGraph pruned;
  const CompatibilityGraph* current = &graph;
  if (params.max_degeneracy > 0 && stats.degeneracy > params.max_degeneracy) {
    pruned = thinDenseCores(graph, params.max_degeneracy, stop, stats.thinned_nodes);
    current = &pruned;
  }
  for (int round = 0;; ++round) {
    if (stopRequested(stop)) {
      stats.cancelled = true;
      stats.complete = false;
      break;
    }
    stats.nodes_searched = nonIsolatedNodes(*current);
    // Keep half of what is left for the retries, so that a search stopped by time still leaves room to
    // search a pruned graph.
    const bool retries_left = round < params.max_pruning_rounds;
    const auto now = Clock::now();
    const auto deadline = retries_left ? now + (final_deadline - now) / 2 : final_deadline;
    const SearchOutcome outcome = searchOnce(*current, params, deadline, visit, stop);
    stats.cliques += outcome.cliques;
    stats.stale_igraph_cleanups += outcome.stale_cleanups;
    stats.cancelled = outcome.cancelled;
    stats.hit_count_limit |= outcome.hit_count;
    stats.hit_time_limit |= outcome.hit_time;
    if (!outcome.error.empty()) {
      stats.error = outcome.error;
      stats.complete = false;
      break;
    }
    stats.complete = !outcome.hit_count && !outcome.hit_time && !outcome.cancelled;
    if (stats.complete || outcome.cancelled || !retries_left || Clock::now() >= final_deadline) break;

    const auto keep_count = static_cast<std::size_t>(params.pruning_keep_fraction * stats.nodes_searched);
    pruned = keepNodes(*current, strongestNodes(nodeStrength(*current), keep_count));
    current = &pruned;
    ++stats.pruning_rounds;
  }
  return stats;
}

}  // namespace mac_registration
