#include "graph_bounds.hpp"

#include <algorithm>
#include <vector>

namespace mac_registration {

std::vector<char> nodesWithinSecondOrderBudget(
    const std::vector<double>& degree, double budget,
    const std::function<double(const std::vector<char>&)>& work_of_kept, const StopFlag* stop,
    std::size_t& kept_nodes) {
  std::size_t nodes = 0;
  for (const double d : degree) nodes += d > 0.0;
  // Each round is judged by the work of the graph it would keep; only the last one is built.
  std::vector<char> keep;
  do {
    nodes = nodes * 7 / 10;
    keep = strongestNodes(degree, nodes);
  } while (nodes > 3 && !stopRequested(stop) && work_of_kept(keep) > budget);
  kept_nodes = nodes;
  return keep;
}

namespace {

// Whether a graph of `edges` on `nodes` has a mean degree above mean_degree (never for 0).
bool denserThan(std::size_t edges, int nodes, double mean_degree) {
  return mean_degree > 0.0 && nodes > 0 && 2.0 * double(edges) / nodes > mean_degree;
}

}  // namespace

SecondOrderOutcome prunedSecondOrderGraph(const UpperRows& first_order, double dense_mean_degree,
                                          int num_threads, const StopFlag* stop) {
  // One 512-bit AND and popcount (eight words) costs about two random-access multiply-adds of the exact sum.
  constexpr double kWordsPerMultiplyAdd = 4.0;
  SecondOrderOutcome out;
  const int n = first_order.numNodes();
  out.counted = denserThan(first_order.numEdges(), n, dense_mean_degree) && neighbourCountsFit(first_order) &&
                countedSecondOrderWork(first_order) / kWordsPerMultiplyAdd < secondOrderWork(first_order);
  if (!out.counted) {
    out.pruned = pruneDenseGraph(
        buildSecondOrderGraph(graphOfRows(first_order, num_threads), num_threads, stop), dense_mean_degree);
    return out;
  }
  const EdgeSums common = countedCommonSums(first_order, num_threads, stop);
  std::size_t edges = 0;
  const float threshold = otsuThresholdOfSums(first_order, common, edges, num_threads);
  // pruneDenseGraph's test, on the second-order graph's edge count.
  const bool dense = denserThan(edges, n, dense_mean_degree);
  out.pruned.graph = triangleEdgesFromSums(first_order, common, dense ? threshold : 0.0f, num_threads);
  out.pruned.reduced = dense;
  out.pruned.removed_edges = dense ? edges - out.pruned.graph.numEdges() : 0;
  return out;
}

BoundedGraph pruneDenseGraph(CompatibilityGraph graph, double dense_mean_degree) {
  BoundedGraph out;
  if (!denserThan(graph.numEdges(), graph.num_nodes, dense_mean_degree)) {
    out.graph = std::move(graph);
    return out;
  }
  out.graph = withoutWeakEdges(graph, otsuEdgeThreshold(graph));
  out.reduced = true;
  out.removed_edges = graph.numEdges() - out.graph.numEdges();
  return out;
}

// Each round keeps at most max_degeneracy of the over-dense nodes, and adding k nodes raises the
// degeneracy by at most k, so one or two rounds usually suffice.
CompatibilityGraph thinDenseCores(const CompatibilityGraph& graph, int max_degeneracy, const StopFlag* stop,
                                  std::size_t& thinned_nodes) {
  CompatibilityGraph current = graph;
  std::vector<char> keep(graph.num_nodes, 1);
  for (int round = 0; round < 8 && !stopRequested(stop); ++round) {
    const std::vector<int> core = coreNumbers(current);
    std::vector<double> strength = nodeStrength(current);
    bool over = false;
    for (int i = 0; i < current.num_nodes; ++i) {
      if (core[i] > max_degeneracy) {
        over = true;
      } else {
        strength[i] = -1.0;  // not a candidate
      }
    }
    if (!over) break;
    const std::vector<char> strongest = strongestNodes(strength, static_cast<std::size_t>(max_degeneracy));
    for (int i = 0; i < current.num_nodes; ++i) {
      if (core[i] > max_degeneracy && !strongest[i]) keep[i] = 0;
    }
    current = keepNodes(graph, keep);
  }
  thinned_nodes = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 0));
  return current;
}

}  // namespace mac_registration
