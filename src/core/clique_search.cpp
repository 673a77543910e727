#include "mac_registration/core/clique_search.hpp"

#include <igraph.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <exception>
#include <numeric>
#include <utility>
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

// The graph the search hands to igraph, as an edge list over its own vertices, each vertex one node or a
// set of true twins. With min_clique_size 3 or more (every valid configuration), only the edges that lie
// in a triangle, and the nodes they join, are kept: such a clique is made of those edges alone, and one
// that is maximal stays maximal without the others, so the cliques are the same. igraph's enumeration
// clears a vector of all its vertices for each vertex it starts from, so the nodes left out would make it
// quadratic for nothing: a chance graph after Otsu's cut keeps many edges in no triangle, and a graph
// reduced or thinned from a large set mostly isolated nodes (igraph 0.10: 1.3 s for 100 000 isolated
// vertices, 16 s for 300 000).
struct SearchGraph {
  std::vector<int> member_begin;        // per vertex, into members (one more entry than vertices)
  std::vector<int> members;             // graph nodes, ascending within each vertex
  std::vector<igraph_integer_t> edges;  // vertex pairs
  bool merged = false;                  // some vertex holds several nodes
};

// The kept edges, ascending (i < j), over the kept nodes, numbered in node order.
struct KeptEdges {
  std::vector<int> node;                   // of each kept index
  std::vector<std::pair<int, int>> edges;  // kept indices
};

KeptEdges keptEdges(const CompatibilityGraph& graph, bool triangles_only) {
  // Two nodes whose degrees add up to more than the nodes with an edge share a neighbour: a dense
  // consensus needs no list walked.
  int active = 0;
  for (int i = 0; i < graph.num_nodes; ++i) active += graph.degree(i) > 0;
  const auto keep = [&](int i, int j) {
    return !triangles_only || graph.degree(i) + graph.degree(j) > active || inTriangle(graph, i, j);
  };
  KeptEdges kept;
  std::vector<int> index_of_node(graph.num_nodes, -1);
  for (int i = 0; i < graph.num_nodes; ++i) {
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) {
      const int j = graph.neighbours[p];
      if (j <= i || !keep(i, j)) continue;
      kept.edges.emplace_back(i, j);
      index_of_node[i] = index_of_node[j] = 0;  // numbered below, in node order
    }
  }
  for (int i = 0; i < graph.num_nodes; ++i) {
    if (index_of_node[i] < 0) continue;
    index_of_node[i] = static_cast<int>(kept.node.size());
    kept.node.push_back(i);
  }
  for (auto& [i, j] : kept.edges) i = index_of_node[i], j = index_of_node[j];
  return kept;
}

// Ascending neighbour lists of the kept edges.
struct KeptLists {
  std::vector<int> offsets;     // per kept index, into neighbours
  std::vector<int> neighbours;  // kept indices, ascending
};

KeptLists keptLists(const KeptEdges& kept) {
  const int n = static_cast<int>(kept.node.size());
  KeptLists lists;
  lists.offsets.assign(n + 1, 0);
  for (const auto& [i, j] : kept.edges) ++lists.offsets[i + 1], ++lists.offsets[j + 1];
  for (int v = 0; v < n; ++v) lists.offsets[v + 1] += lists.offsets[v];
  lists.neighbours.resize(lists.offsets[n]);
  std::vector<int> next(lists.offsets.begin(), lists.offsets.end() - 1);
  // The edges come in ascending (i, j): each list gets its lower ends, then its upper ones, in order.
  for (const auto& [i, j] : kept.edges) {
    lists.neighbours[next[i]++] = j;
    lists.neighbours[next[j]++] = i;
  }
  return lists;
}

// Whether u and v are true twins, N(u) + u == N(v) + v: adjacent, with the same neighbours otherwise.
bool trueTwins(const KeptLists& lists, int u, int v) {
  const auto first = [&](int w) { return lists.neighbours.begin() + lists.offsets[w]; };
  const auto last = [&](int w) { return lists.neighbours.begin() + lists.offsets[w + 1]; };
  if (last(u) - first(u) != last(v) - first(v) || !std::binary_search(first(u), last(u), v)) return false;
  auto a = first(u), b = first(v);
  while (true) {  // the lists without v and u, compared
    if (a != last(u) && *a == v) ++a;
    if (b != last(v) && *b == u) ++b;
    if (a == last(u) || b == last(v)) return a == last(u) && b == last(v);
    if (*a++ != *b++) return false;
  }
}

// The class of true twins of each kept index, classes numbered by their lowest index; `classes` receives
// how many. Twins share their closed neighbourhood, so an order-free hash of it groups them (one pass over
// the edges), and only a group of two or more needs the lists that check each candidate.
std::vector<int> twinClasses(const KeptEdges& kept, int& classes) {
  const int n = static_cast<int>(kept.node.size());
  const auto mix = [](std::uint64_t x) {  // splitmix64's finaliser
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
  };
  std::vector<std::pair<std::uint64_t, int>> keyed(n);
  for (int v = 0; v < n; ++v) keyed[v] = {mix(std::uint64_t(v)), v};
  for (const auto& [i, j] : kept.edges)
    keyed[i].first += mix(std::uint64_t(j)), keyed[j].first += mix(std::uint64_t(i));
  std::sort(keyed.begin(), keyed.end());
  std::vector<int> class_of(n);
  std::iota(class_of.begin(), class_of.end(), 0);
  classes = n;
  bool candidates = false;
  for (int k = 1; k < n && !candidates; ++k) candidates = keyed[k].first == keyed[k - 1].first;
  if (!candidates) return class_of;
  const KeptLists lists = keptLists(kept);
  std::vector<int> representative(n);
  for (int g = 0; g < n;) {
    int end = g;
    while (end < n && keyed[end].first == keyed[g].first) ++end;
    for (int k = g; k < end; ++k) {  // ascending index within the group: the first of a class leads it
      const int v = keyed[k].second;
      representative[v] = v;
      for (int r = g; r < k; ++r) {
        const int u = keyed[r].second;
        if (representative[u] == u && trueTwins(lists, u, v)) {
          representative[v] = u;
          break;
        }
      }
    }
    g = end;
  }
  classes = 0;
  for (int v = 0; v < n; ++v) class_of[v] = representative[v] == v ? classes++ : class_of[representative[v]];
  return class_of;
}

// Every maximal clique holds all of a node's true twins or none of them (each twin is adjacent to the
// rest of any clique of the other), and twins are adjacent to the same other nodes: merged into one vertex
// each, they leave a graph whose maximal cliques are those of the whole, a vertex standing for its twins.
// A consensus core is mostly twins (a complete subgraph is one class), and igraph's search costs the cube
// of a complete subgraph's size (0.2 ms at 32 nodes, 9 ms at 128, 67 ms at 256). Only when no size cap
// applies: a cap counts nodes, not vertices.
SearchGraph searchGraph(const CompatibilityGraph& graph, const CliqueSearchParams& params) {
  const KeptEdges kept = keptEdges(graph, params.min_clique_size >= 3);
  const int n = static_cast<int>(kept.node.size());
  int classes = n;
  std::vector<int> class_of(n);
  std::iota(class_of.begin(), class_of.end(), 0);
  if (params.max_clique_size == 0) class_of = twinClasses(kept, classes);
  SearchGraph out;
  out.merged = classes < n;
  out.member_begin.assign(classes + 1, 0);
  for (int v = 0; v < n; ++v) ++out.member_begin[class_of[v] + 1];
  for (int c = 0; c < classes; ++c) out.member_begin[c + 1] += out.member_begin[c];
  out.members.resize(n);
  std::vector<int> next(out.member_begin.begin(), out.member_begin.end() - 1);
  for (int v = 0; v < n; ++v) out.members[next[class_of[v]]++] = kept.node[v];
  // Twins have the same edges: those of the first of each class stand for it.
  const auto leads = [&](int v) { return kept.node[v] == out.members[out.member_begin[class_of[v]]]; };
  out.edges.reserve(2 * kept.edges.size());
  for (const auto& [i, j] : kept.edges) {
    if (class_of[i] == class_of[j] || !leads(i) || !leads(j)) continue;
    out.edges.push_back(class_of[i]);
    out.edges.push_back(class_of[j]);
  }
  return out;
}

// Copies the search graph into igraph and streams its maximal cliques to `state`; returns igraph's code.
igraph_error_t enumerateCliques(const CompatibilityGraph& graph, const CliqueSearchParams& params,
                                SearchState& state) {
  SearchGraph search = searchGraph(graph, params);
  state.member_begin = std::move(search.member_begin);
  state.members = std::move(search.members);
  state.min_size = static_cast<std::size_t>(params.min_clique_size);
  igraph_vector_int_t edges;
  igraph_vector_int_view(&edges, search.edges.data(), igraph_integer_t(search.edges.size()));
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
