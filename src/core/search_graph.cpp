#include "search_graph.hpp"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <utility>

namespace mac_registration {
namespace {

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

}  // namespace

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

}  // namespace mac_registration
