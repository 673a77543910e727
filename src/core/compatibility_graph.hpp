#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/stop_flag.hpp"
#include "uninitialised_vector.hpp"

namespace mac_registration {

// An undirected weighted graph as sorted neighbour lists (CSR), each edge stored in both directions.
// Node k is correspondence k. There is no N x N matrix: memory is O(N + edges).
struct CompatibilityGraph {
  int num_nodes = 0;
  std::vector<std::int64_t> offsets;  // size num_nodes + 1
  std::vector<int> neighbours;        // ascending within each node's range
  std::vector<float> weights;         // aligned with neighbours

  std::size_t numEdges() const { return neighbours.size() / 2; }
  int degree(int node) const { return static_cast<int>(offsets[node + 1] - offsets[node]); }
  // Weight of edge (a, b), 0 when there is none. O(log degree).
  float weight(int a, int b) const;
};

// A graph as the rows of its upper edges: row i holds node i's neighbours j > i, ascending, with their
// weights; degree[i] counts all of i's neighbours (its row and the rows that name it). The rows point into
// buffers owned elsewhere: the first-order pass's (FirstOrderRows), or a graph's lists (upperRowsOf). The
// dense path of the second-order weights reads the pass's rows as they are: the lists of a dense chance
// graph (both directions of a million edges) cost as much as the pair test that found its edges.
struct UpperRows {
  std::vector<const int*> to;
  std::vector<const float*> weight;
  std::vector<int> count;
  std::vector<std::int64_t> degree;

  int numNodes() const { return static_cast<int>(count.size()); }
  std::size_t numEdges() const;
  // Where each row starts among all the rows' entries laid end to end (numNodes() + 1 values): the index
  // of a value kept per edge, as EdgeSums.
  std::vector<std::int64_t> rowStarts() const;
};

// The upper rows of a graph, pointing into its lists: valid while the graph lives, unchanged.
UpperRows upperRowsOf(const CompatibilityGraph& graph);

// The lists of the graph of `rows`, on num_threads: bit for bit the lists the tests build edge by edge
// (graphFromUpperRows).
CompatibilityGraph graphOfRows(const UpperRows& rows, int num_threads = 1);

// What the bounds of the first-order graph did. Nodes of the graph are all the correspondences; those a
// bound left out are isolated.
struct FirstOrderBounds {
  // More than max_correspondences were given: the pairs were tested among an evenly spaced subset of
  // sampled_to of them.
  bool sampled = false;
  std::size_t sampled_to = 0;
  // Compatible pairs found by that test, every one counted even past max_edges.
  std::size_t compatible_pairs = 0;
  // More than max_edges compatible pairs: the graph holds only the reduced_to correspondences of highest
  // degree (the true degree, from the counts of the full pass).
  bool reduced = false;
  std::size_t reduced_to = 0;
  // The second_order_budget of the builder acted: the graph holds only the edges among the
  // second_order_kept_nodes correspondences the budget keeps (nodesWithinSecondOrderBudget).
  bool second_order_bounded = false;
  std::size_t second_order_kept_nodes = 0;
  std::size_t second_order_removed_edges = 0;
  // The stop flag ended the pass: the graph is incomplete and not to be used.
  bool cancelled = false;
};

// The first-order graph as the pass left it: its upper rows, in buffers this owns.
struct FirstOrderRows : FirstOrderBounds {
  UpperRows rows;
  std::shared_ptr<const void> buffers;
};

// First-order compatibility graph (FOG, paper Eq. 1-2): an edge where the score is >= t_cmp, weighted by
// the score. Both scores are monotone in d, so each pair is tested against a precomputed bound on d^2.
// O(min(N, max_correspondences)^2) pair tests, then O(sqrt(max_edges)^2) more if the edges overflow; memory
// O(N + max_edges). The same graph whatever num_threads. A raised `stop` ends the pass within a row of pairs.
// second_order_budget [multiply-adds] (graph.max_second_order_work), 0 = none: a graph whose second-order
// pass would cost more keeps only the edges among its highest-degree nodes (inliers of a dense consensus
// have the highest degree), 30 % fewer a round until it fits (nodesWithinSecondOrderBudget), chosen from
// the pass's rows before any list is built (a dense consensus is millions of edges, most of which the
// budget drops), with second_order_bounded set.
FirstOrderRows firstOrderRows(const CorrespondenceSet& correspondences, const GraphParams& params,
                              int num_threads, const StopFlag* stop = nullptr,
                              double second_order_budget = 0.0);

// Second-order weights (paper Eq. 4): w_ij = S_ij * sum_k S_ik S_jk over common neighbours k, on the
// sparse lists. Edges in no triangle get weight 0 and are removed. A raised `stop` ends the pass within a
// row, leaving the graph incomplete: the caller checks the flag before using it.
CompatibilityGraph buildSecondOrderGraph(const CompatibilityGraph& first_order, int num_threads,
                                         const StopFlag* stop = nullptr);

// A value for each upper edge, in the order of the rows laid end to end (UpperRows::rowStarts).
using EdgeSums = UninitialisedVector<float>;

// Eq. 4 estimated from counts, for dense graphs: sum_k S_ik S_jk is taken as c_ij m_i m_j, with c_ij the
// number of common neighbours of i and j (a popcount of two neighbour bitsets) and m_i the mean weight of
// i's edges. Every weight lies in [t_cmp, 1], so the estimate is within a factor t_cmp^2 of the exact sum
// (2 % at t_cmp 0.99); the same edges as buildSecondOrderGraph (those in a triangle). O(N) words per
// edge instead of O(degree) random loads, and O(N^2 / 8) bytes of bitsets; the same sums whatever
// num_threads. This is that estimate for every edge of the rows (0 for an edge in no triangle), before any
// graph is built; a raised `stop` leaves it incomplete, as buildSecondOrderGraph.
EdgeSums countedCommonSums(const UpperRows& first_order, int num_threads, const StopFlag* stop = nullptr);

// The graph of those sums (the edges with a positive sum, weighted S_ij * sum) with only its edges of
// weight >= min_weight: the counted second-order graph for 0, and withoutWeakEdges of it for
// another weight, bit for bit, without building it first. The same graph whatever num_threads.
CompatibilityGraph triangleEdgesFromSums(const UpperRows& first_order, const EdgeSums& common,
                                         float min_weight, int num_threads = 1);

// otsuEdgeThreshold of triangleEdgesFromSums(first_order, common, 0) and that graph's edge count, without
// building it. The same whatever num_threads.
float otsuThresholdOfSums(const UpperRows& first_order, const EdgeSums& common, std::size_t& edges,
                          int num_threads = 1);

// Whether the bitsets of countedCommonSums on this graph stay within 64 MB.
bool neighbourCountsFit(const UpperRows& first_order);

// 64-bit words countedCommonSums would AND and count on this graph.
double countedSecondOrderWork(const UpperRows& first_order);

// Multiply-adds buildSecondOrderGraph would spend on the graph of these rows.
double secondOrderWork(const UpperRows& first_order);

// Multiply-adds buildSecondOrderGraph would spend on this graph.
double secondOrderWork(const CompatibilityGraph& graph);

// secondOrderWork(keepNodes(graph, keep)), without building that graph; +infinity as soon as it is known
// to exceed `limit` (a bound's test needs no more). The same whatever num_threads.
double secondOrderWorkOfNodes(const CompatibilityGraph& graph, const std::vector<char>& keep,
                              double limit = std::numeric_limits<double>::infinity(), int num_threads = 1);

// The graph with only the nodes where keep[node] is true; node ids are unchanged, dropped nodes isolated.
// The same graph whatever num_threads (as withoutWeakEdges).
CompatibilityGraph keepNodes(const CompatibilityGraph& graph, const std::vector<char>& keep,
                             int num_threads = 1);

// The `count` nodes of highest `score` (ties to the lower index) as a keep mask.
std::vector<char> strongestNodes(const std::vector<double>& score, std::size_t count);

// Otsu's threshold of the edge weights (256 bins between the lightest and the heaviest edge): the cut that
// best separates them into two classes. On a dense second-order graph these are the edges among outliers
// (few common neighbours) and the edges among inliers (many).
float otsuEdgeThreshold(const CompatibilityGraph& graph);

// The graph without its edges lighter than `threshold`.
CompatibilityGraph withoutWeakEdges(const CompatibilityGraph& graph, float threshold, int num_threads = 1);

// Core number of each node (the largest k such that the node is in the k-core), Batagelj-Zaversnik, O(E).
// The largest is the graph's degeneracy, which bounds clique sizes and the cost of the clique search.
std::vector<int> coreNumbers(const CompatibilityGraph& graph);

// Sum of incident edge weights per node.
std::vector<double> nodeStrength(const CompatibilityGraph& graph);

}  // namespace mac_registration
