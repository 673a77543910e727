#include "graph_builders.hpp"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <utility>
#include <vector>

namespace mac_registration {

CompatibilityGraph graphFromUpperRows(int num_nodes, const std::vector<std::vector<UpperEdge>>& rows) {
  CompatibilityGraph graph;
  graph.num_nodes = num_nodes;
  std::vector<std::int64_t> degree(num_nodes, 0);
  for (int i = 0; i < num_nodes; ++i) {
    degree[i] += static_cast<std::int64_t>(rows[i].size());
    for (const auto& e : rows[i]) ++degree[e.to];
  }
  graph.offsets.assign(num_nodes + 1, 0);
  std::partial_sum(degree.begin(), degree.end(), graph.offsets.begin() + 1);
  graph.neighbours.resize(graph.offsets.back());
  graph.weights.resize(graph.offsets.back());
  // Each list is its lower neighbours (the rows that name the node) then its own row, so every list comes
  // out sorted without a sort. The rows go to the tails in order; the lower entries are written a block of
  // nodes at a time, walking all the rows for each block, so that the lists being written stay cached
  // (edge by edge, every write of a dense graph would miss).
  constexpr std::int64_t kEntriesPerBlock = 32768;
  std::vector<std::int64_t> cursor(graph.offsets.begin(), graph.offsets.end() - 1);
  for (int i = 0; i < num_nodes; ++i) {
    std::int64_t at = graph.offsets[i + 1] - static_cast<std::int64_t>(rows[i].size());
    for (const auto& e : rows[i]) graph.neighbours[at] = e.to, graph.weights[at++] = e.weight;
  }
  std::vector<std::size_t> next(num_nodes, 0);  // first entry of each row not yet mirrored
  for (int block_begin = 0; block_begin < num_nodes;) {
    int block_end = block_begin + 1;
    while (block_end < num_nodes &&
           graph.offsets[block_end + 1] - graph.offsets[block_begin] <= kEntriesPerBlock)
      ++block_end;
    for (int i = 0; i < block_end; ++i) {
      const auto& row = rows[i];
      std::size_t& k = next[i];
      for (; k < row.size() && row[k].to < block_end; ++k) {
        const int j = row[k].to;
        graph.neighbours[cursor[j]] = i;
        graph.weights[cursor[j]++] = row[k].weight;
      }
    }
    block_begin = block_end;
  }
  return graph;
}

FirstOrderGraph buildFirstOrderGraph(const CorrespondenceSet& correspondences, const GraphParams& params,
                                     int num_threads, const StopFlag* stop, double second_order_budget) {
  FirstOrderRows rows = firstOrderRows(correspondences, params, num_threads, stop, second_order_budget);
  FirstOrderGraph result;
  static_cast<FirstOrderBounds&>(result) = rows;
  result.graph = graphOfRows(rows.rows, num_threads);
  return result;
}

CompatibilityGraph buildCountedSecondOrderGraph(const CompatibilityGraph& fog, int num_threads,
                                                const StopFlag* stop) {
  const UpperRows rows = upperRowsOf(fog);
  return triangleEdgesFromSums(rows, countedCommonSums(rows, num_threads, stop), 0.0f, num_threads);
}

BoundedGraph boundSecondOrderWork(CompatibilityGraph graph, double budget, int num_threads,
                                  const StopFlag* stop) {
  BoundedGraph out;
  if (secondOrderWork(graph) <= budget) {
    out.graph = std::move(graph);
    return out;
  }
  std::vector<double> degree(graph.num_nodes);
  for (int i = 0; i < graph.num_nodes; ++i) degree[i] = graph.degree(i);
  const std::vector<char> keep = nodesWithinSecondOrderBudget(
      degree, budget,
      [&](const std::vector<char>& kept) { return secondOrderWorkOfNodes(graph, kept, budget, num_threads); },
      stop, out.kept_nodes);
  out.graph = keepNodes(graph, keep, num_threads);
  out.reduced = true;
  out.removed_edges = graph.numEdges() - out.graph.numEdges();
  return out;
}

}  // namespace mac_registration
