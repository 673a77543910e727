#include "clique_search.hpp"

#include <igraph.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <utility>
#include <vector>

#include "graph_bounds.hpp"
#include "igraph_session.hpp"
#include "search_graph.hpp"
#include "thread_cpu_clock.hpp"

namespace mac_registration {
namespace {

// The budget is counted in the searching thread's CPU time: see CliqueSearchParams::time_limit.
using BudgetClock = ThreadCpuClock;

struct SearchState {
  const CliqueVisitor* visit = nullptr;
  const StopFlag* stop = nullptr;
  std::size_t limit = 0;
  BudgetClock::time_point deadline;
  std::size_t count = 0;
  bool hit_count = false;
  bool hit_time = false;
  bool cancelled = false;
  std::exception_ptr visitor_error;
  // The graph nodes of igraph vertex v: members[member_begin[v] .. member_begin[v + 1]), ascending.
  std::vector<int> member_begin;
  std::vector<int> members;
  std::size_t min_size = 0;  // of the cliques streamed, in graph nodes
  std::vector<int> nodes;
};

// Called by igraph for each maximal clique. Exceptions must not unwind through igraph's C frames, so a
// throwing visitor stops the search and its exception is rethrown afterwards.
igraph_error_t onClique(const igraph_vector_int_t* clique, void* arg) {
  auto& state = *static_cast<SearchState*>(arg);
  state.nodes.clear();
  for (igraph_integer_t k = 0; k < igraph_vector_int_size(clique); ++k) {
    const auto v = VECTOR(*clique)[k];
    state.nodes.insert(state.nodes.end(), state.members.begin() + state.member_begin[v],
                       state.members.begin() + state.member_begin[v + 1]);
  }
  if (state.nodes.size() < state.min_size) return IGRAPH_SUCCESS;  // a merged vertex too small alone
  std::sort(state.nodes.begin(), state.nodes.end());
  try {
    (*state.visit)(state.nodes.data(), state.nodes.size());
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
  // A clock read costs up to a microsecond; every 64th clique keeps the overshoot small and the cost nil.
  if ((state.count & 63u) == 0 && BudgetClock::now() > state.deadline) {
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
  std::chrono::steady_clock::duration waited{};  // for igraph's lock
  std::string error;
};

// Copies the search graph into igraph and streams its maximal cliques to `state`; returns igraph's code.
igraph_error_t enumerateCliques(SearchGraph search, const CliqueSearchParams& params, SearchState& state) {
  state.member_begin = std::move(search.member_begin);
  state.members = std::move(search.members);
  state.min_size = static_cast<std::size_t>(params.min_clique_size);
  igraph_vector_int_t edges;
  static const igraph_integer_t kNoEdges = 0;  // a view needs storage even for no edges
  igraph_vector_int_view(&edges, search.edges.empty() ? &kNoEdges : search.edges.data(),
                         igraph_integer_t(search.edges.size()));
  igraph_t ig;
  const auto vertices = igraph_integer_t(state.member_begin.size()) - 1;
  const igraph_error_t created = igraph_create(&ig, &edges, vertices, IGRAPH_UNDIRECTED);
  if (created != IGRAPH_SUCCESS) return created;
  // A merged vertex may alone be a clique of min_clique_size nodes: the sizes are checked as they come.
  const igraph_integer_t min_vertices = search.merged ? 1 : params.min_clique_size;
  const igraph_error_t code =
      igraph_maximal_cliques_callback(&ig, onClique, &state, min_vertices, params.max_clique_size);
  igraph_destroy(&ig);
  return code;
}

// One search of `graph`, until `budget_end` or, with retries left, until half of what is left of the budget
// when the search starts: a search stopped by time still leaves room to search a pruned graph. The budget
// starts when igraph's lock is held, whatever the wait for it (and being counted in this thread's CPU time,
// the wait spends none of it either way).
SearchOutcome searchOnce(const CompatibilityGraph& graph, const CliqueSearchParams& params,
                         BudgetClock::time_point budget_end, bool retries_left, const CliqueVisitor& visit,
                         const StopFlag* stop) {
  SearchOutcome outcome;
  // The search graph needs no igraph: built before the lock, so that others wait for igraph alone.
  SearchGraph search = searchGraph(graph, params);
  IgraphSession session(stop);
  outcome.waited = session.waited();
  if (!session.held()) {
    outcome.cancelled = true;  // stopped while waiting for the lock
    return outcome;
  }
  const auto now = BudgetClock::now();
  SearchState state;
  state.visit = &visit;
  state.stop = stop;
  state.limit = params.max_cliques;
  state.deadline = retries_left && budget_end > now ? now + (budget_end - now) / 2 : budget_end;
  session.interruptAt(state.deadline);
  const igraph_error_t code = enumerateCliques(std::move(search), params, state);
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
  // Capped at 30 years, so that no finite limit overflows the clock's nanoseconds.
  const auto budget = std::chrono::duration_cast<BudgetClock::duration>(
      std::chrono::duration<double>(std::min(params.time_limit, 1e9)));
  const auto budget_end = BudgetClock::now() + budget;

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
    const bool retries_left = round < params.max_pruning_rounds;
    const SearchOutcome outcome = searchOnce(*current, params, budget_end, retries_left, visit, stop);
    stats.igraph_wait_ms += std::chrono::duration<double, std::milli>(outcome.waited).count();
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
    if (stats.complete || outcome.cancelled || !retries_left || BudgetClock::now() >= budget_end) break;

    const auto keep_count = static_cast<std::size_t>(params.pruning_keep_fraction * stats.nodes_searched);
    pruned = keepNodes(*current, strongestNodes(nodeStrength(*current), keep_count));
    current = &pruned;
    ++stats.pruning_rounds;
  }
  return stats;
}

}  // namespace mac_registration
