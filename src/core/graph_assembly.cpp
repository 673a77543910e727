#include "graph_assembly.hpp"

#include <omp.h>

#include <algorithm>

namespace mac_registration {

CompatibilityGraph graphWithDegrees(const std::vector<std::int64_t>& degree) {
  const int n = static_cast<int>(degree.size());
  CompatibilityGraph graph;
  graph.num_nodes = n;
  graph.offsets.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) graph.offsets[v + 1] = graph.offsets[v] + degree[v];
  graph.neighbours.resize(graph.offsets.back());
  graph.weights.resize(graph.offsets.back());
  return graph;
}

void mirrorRows(const UpperRows& rows, CompatibilityGraph& graph, int num_threads) {
  const int n = graph.num_nodes;
  std::vector<std::int64_t> lower_prefix(n + 1, 0);
  for (int v = 0; v < n; ++v) lower_prefix[v + 1] = lower_prefix[v] + graph.degree(v) - rows.count[v];
  // The lists written at once, a cache line of each in flight: 2048 nodes keep 256 kB of lines in cache.
  constexpr int kNodesPerBlock = 2048;
#pragma omp parallel num_threads(num_threads)
  {
    const int threads = omp_get_num_threads(), thread = omp_get_thread_num();
    const auto boundary = [&](int t) {
      if (t == threads) return n;
      const std::int64_t share = lower_prefix[n] * t / threads;
      return static_cast<int>(std::lower_bound(lower_prefix.begin(), lower_prefix.begin() + n, share) -
                              lower_prefix.begin());
    };
    const int first = boundary(thread), last = boundary(thread + 1);
    std::vector<int> next(last);  // the first entry of each row not yet mirrored
    for (int i = 0; i < last; ++i) {
      next[i] =
          static_cast<int>(std::lower_bound(rows.to[i], rows.to[i] + rows.count[i], first) - rows.to[i]);
    }
    std::vector<std::int64_t> cursor(graph.offsets.begin() + first, graph.offsets.begin() + last);
    int* const neighbours = graph.neighbours.data();
    float* const weights = graph.weights.data();
    for (int block_begin = first; block_begin < last; block_begin += kNodesPerBlock) {
      const int block_end = std::min(last, block_begin + kNodesPerBlock);
      for (int i = 0; i < block_end; ++i) {
        const int* const to = rows.to[i];
        const float* const weight = rows.weight[i];
        const int count = rows.count[i];
        int k = next[i];
        for (; k < count && to[k] < block_end; ++k) {
          const std::int64_t at = cursor[to[k] - first]++;
          neighbours[at] = i;
          weights[at] = weight[k];
        }
        next[i] = k;
      }
    }
  }
}

std::size_t UpperRows::numEdges() const {
  std::size_t edges = 0;
  for (const int c : count) edges += static_cast<std::size_t>(c);
  return edges;
}

std::vector<std::int64_t> UpperRows::rowStarts() const {
  std::vector<std::int64_t> starts(count.size() + 1, 0);
  for (std::size_t i = 0; i < count.size(); ++i) starts[i + 1] = starts[i] + count[i];
  return starts;
}

UpperRows upperRowsOf(const CompatibilityGraph& graph) {
  const int n = graph.num_nodes;
  UpperRows rows;
  rows.to.resize(n);
  rows.weight.resize(n);
  rows.count.resize(n);
  rows.degree.resize(n);
  for (int i = 0; i < n; ++i) {
    const auto upper = std::upper_bound(graph.neighbours.begin() + graph.offsets[i],
                                        graph.neighbours.begin() + graph.offsets[i + 1], i) -
                       graph.neighbours.begin();
    rows.to[i] = graph.neighbours.data() + upper;
    rows.weight[i] = graph.weights.data() + upper;
    rows.count[i] = static_cast<int>(graph.offsets[i + 1] - upper);
    rows.degree[i] = graph.degree(i);
  }
  return rows;
}

CompatibilityGraph graphOfRows(const UpperRows& rows, int num_threads) {
  CompatibilityGraph graph = graphWithDegrees(rows.degree);
  const int n = graph.num_nodes;
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads)
  for (int v = 0; v < n; ++v) {
    const std::int64_t at = graph.offsets[v + 1] - rows.count[v];
    std::copy(rows.to[v], rows.to[v] + rows.count[v], graph.neighbours.begin() + at);
    std::copy(rows.weight[v], rows.weight[v] + rows.count[v], graph.weights.begin() + at);
  }
  mirrorRows(rows, graph, num_threads);
  return graph;
}

}  // namespace mac_registration
