#include "compatibility_graph.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>

#include "graph_assembly.hpp"

namespace mac_registration {
namespace {

// Sum over j's list, in its ascending order, of row[k] * S_jk: with row = i's weights scattered densely (0
// off i's list, and adding +0 changes no float) this is the common-neighbour sum of edge (i, j).
float listSum(const CompatibilityGraph& fog, const float* row, int j) {
  float sum = 0.0f;
  for (auto q = fog.offsets[j]; q < fog.offsets[j + 1]; ++q) sum += row[fog.neighbours[q]] * fog.weights[q];
  return sum;
}

// out[p - first] = listSum(fog, row, j) for every first-order edge (i, j) at list position p in
// [first, last).
// One sum is a chain of dependent additions whose latency bounds a loop over one list; kLanes edges are
// summed side by side, each lane taking the next edge as soon as its own ends, so that the chains overlap
// while each keeps its own order (every sum is exactly listSum's). Short lists are summed one by one: there
// the lanes cost more than the overlap gains. Cross-lane vectorization is off: packing the lanes' scalar
// loads into vectors costs more shuffles than it saves.
__attribute__((optimize("no-tree-slp-vectorize"))) void commonNeighbourSums(const CompatibilityGraph& fog,
                                                                            const float* row,
                                                                            std::int64_t first,
                                                                            std::int64_t last, float* out) {
  constexpr int kLanes = 4;
  constexpr std::int64_t kMinMeanLength = 64;
  const int* neighbours = fog.neighbours.data();
  const float* weights = fog.weights.data();
  std::int64_t work = 0;
  for (auto p = first; p < last; ++p) work += fog.degree(neighbours[p]);
  std::int64_t next = first;
  if (last - first >= kLanes && work >= kMinMeanLength * (last - first)) {
    const int* list[kLanes];
    const float* list_weight[kLanes];
    std::int64_t left[kLanes], slot[kLanes];
    float sum[kLanes];
    auto start = [&](int l) {
      const int j = neighbours[next];
      list[l] = neighbours + fog.offsets[j], list_weight[l] = weights + fog.offsets[j];
      left[l] = fog.degree(j), slot[l] = next++, sum[l] = 0.0f;
    };
    for (int l = 0; l < kLanes; ++l) start(l);
    bool all_busy = true;
    while (all_busy) {
      std::int64_t steps = left[0];
      for (int l = 1; l < kLanes; ++l) steps = std::min(steps, left[l]);
      for (std::int64_t t = 0; t < steps; ++t) {
#pragma GCC unroll 4
        for (int l = 0; l < kLanes; ++l) sum[l] += row[list[l][t]] * list_weight[l][t];
      }
      for (int l = 0; l < kLanes; ++l) {
        list[l] += steps, list_weight[l] += steps, left[l] -= steps;
        if (left[l] > 0) continue;
        out[slot[l] - first] = sum[l];
        if (next < last) {
          start(l);
        } else {
          all_busy = false;
        }
      }
    }
    for (int l = 0; l < kLanes; ++l) {
      if (left[l] == 0) continue;
      float rest = sum[l];
      for (std::int64_t t = 0; t < left[l]; ++t) rest += row[list[l][t]] * list_weight[l][t];
      out[slot[l] - first] = rest;
    }
  }
  for (; next < last; ++next) out[next - first] = listSum(fog, row, neighbours[next]);
}

// The graph with the list entries (node i, position p) that `keep` accepts, weighted by weight_of(p).
// `keep` must accept an edge in both of its directions or in neither, and weight_of must give both the
// same weight; the lists stay ascending, as a filter of ascending lists. Two sequential passes over the
// lists, where rebuilding from upper rows would scatter every edge twice.
template <typename KeepEntry, typename WeightOf>
CompatibilityGraph filteredGraph(const CompatibilityGraph& graph, KeepEntry keep, WeightOf weight_of,
                                 int num_threads) {
  const int n = graph.num_nodes;
  CompatibilityGraph out;
  out.num_nodes = n;
  out.offsets.assign(n + 1, 0);
  // Each list is counted, then written, by one thread: the same graph whatever the thread count.
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads)
  for (int i = 0; i < n; ++i) {
    std::int64_t kept = 0;
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) kept += keep(i, p) ? 1 : 0;
    out.offsets[i + 1] = kept;
  }
  for (int i = 0; i < n; ++i) out.offsets[i + 1] += out.offsets[i];
  out.neighbours.resize(out.offsets.back());
  out.weights.resize(out.offsets.back());
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads)
  for (int i = 0; i < n; ++i) {
    std::int64_t next = out.offsets[i];
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) {
      if (!keep(i, p)) continue;
      out.neighbours[next] = graph.neighbours[p];
      out.weights[next++] = weight_of(p);
    }
  }
  return out;
}

template <typename KeepEntry>
CompatibilityGraph filteredGraph(const CompatibilityGraph& graph, KeepEntry keep, int num_threads) {
  return filteredGraph(
      graph, keep, [&](std::int64_t p) { return graph.weights[p]; }, num_threads);
}

constexpr int kOtsuBins = 256;

// The bin of weight w among kOtsuBins between low and low + span.
int otsuBin(float w, double low, double span) {
  return std::min(kOtsuBins - 1, int((w - low) / span * kOtsuBins));
}

// Otsu's cut of a histogram of `total` weights from low to low + span: the bin edge of the largest
// between-class variance. The counts are integers: the same whatever order they were summed in.
float otsuCut(const std::vector<double>& count, double total, double low, double span) {
  double sum_all = 0.0;
  for (int b = 0; b < kOtsuBins; ++b) sum_all += b * count[b];
  double below = 0.0, sum_below = 0.0, best_variance = -1.0;
  int best_bin = 0;
  for (int b = 0; b < kOtsuBins - 1; ++b) {
    below += count[b];
    sum_below += b * count[b];
    const double above = total - below;
    if (below == 0.0 || above == 0.0) continue;
    const double mean_below = sum_below / below, mean_above = (sum_all - sum_below) / above;
    const double between = below * above * (mean_below - mean_above) * (mean_below - mean_above);
    if (between > best_variance) best_variance = between, best_bin = b;
  }
  return float(low + span * (best_bin + 1) / kOtsuBins);
}

// Otsu's cut of a set of weights that `each_weight(visit)` lists, each edge once (kOtsuBins bins between
// the lightest and the heaviest): the cut that best separates them into two classes. `edges` is how many.
template <typename EachWeight>
float otsuThreshold(EachWeight each_weight, std::size_t edges) {
  if (edges == 0) return 0.0f;
  float lightest = 0.0f, heaviest = 0.0f;
  bool first = true;
  each_weight([&](float w) {
    lightest = first || w < lightest ? w : lightest;
    heaviest = first || w > heaviest ? w : heaviest;
    first = false;
  });
  const double low = lightest, span = double(heaviest) - low;
  if (!(span > 0.0)) return lightest;
  std::vector<double> count(kOtsuBins, 0.0);
  each_weight([&](float w) { count[otsuBin(w, low, span)] += 1.0; });
  return otsuCut(count, double(edges), low, span);
}

}  // namespace

float CompatibilityGraph::weight(int a, int b) const {
  const auto first = neighbours.begin() + offsets[a];
  const auto last = neighbours.begin() + offsets[a + 1];
  const auto it = std::lower_bound(first, last, b);
  return (it != last && *it == b) ? weights[it - neighbours.begin()] : 0.0f;
}

double secondOrderWork(const CompatibilityGraph& graph) {
  // Each upper edge (i, j) costs degree(j): node j is the upper end of its lower neighbours, the head of
  // its ascending list. Integers below 2^53, so the double sum is exact in any order.
  double work = 0.0;
  for (int j = 0; j < graph.num_nodes; ++j) {
    const auto first = graph.neighbours.begin() + graph.offsets[j];
    const auto lower = std::lower_bound(first, graph.neighbours.begin() + graph.offsets[j + 1], j) - first;
    work += double(lower) * graph.degree(j);
  }
  return work;
}

double secondOrderWork(const UpperRows& rows) { return secondOrderWorkOfDegrees(rows.degree, rows.count); }

CompatibilityGraph buildSecondOrderGraph(const CompatibilityGraph& fog, int num_threads,
                                         const StopFlag* stop) {
  const int n = fog.num_nodes;
  const UpperRows rows = upperRowsOf(fog);
  const std::vector<std::int64_t> start = rows.rowStarts();
  // Common-neighbour sum of each upper edge, in the order of the rows (0 where a stop left it).
  EdgeSums common(start.back(), 0.0f);
#pragma omp parallel num_threads(num_threads)
  {
    // Row i's weights scattered densely, so that a common neighbour k of (i, j) is found by one load while
    // walking j's list: O(sum over edges of degree) with no N x N matrix.
    std::vector<float> row_i(n, 0.0f);
#pragma omp for schedule(dynamic, 8)
    for (int i = 0; i < n; ++i) {
      if (stopRequested(stop)) continue;
      const auto begin = fog.offsets[i], end = fog.offsets[i + 1];
      for (auto p = begin; p < end; ++p) row_i[fog.neighbours[p]] = fog.weights[p];
      // The upper edges of i are the tail of its ascending list: its row.
      const std::int64_t upper = rows.to[i] - fog.neighbours.data();
      commonNeighbourSums(fog, row_i.data(), upper, end, common.data() + start[i]);
      for (auto p = begin; p < end; ++p) row_i[fog.neighbours[p]] = 0.0f;
    }
  }
  return triangleEdgesFromSums(rows, common, 0.0f, num_threads);
}

CompatibilityGraph triangleEdgesFromSums(const UpperRows& fog, const EdgeSums& common, float min_weight,
                                         int num_threads) {
  // The kept entries of each first-order row are its node's row in the graph: counted first (at both
  // ends, for the offsets), then compacted straight into the tails of the lists and mirrored from there,
  // as graphOfRows does.
  const int n = fog.numNodes();
  const std::vector<std::int64_t> start = fog.rowStarts();
  const auto kept = [&](int i, int c) {
    const float sum = common[start[i] + c];
    return (sum > 0.0f) & (fog.weight[i][c] * sum >= min_weight);  // both: no branch
  };
  UpperRows rows;
  rows.count.assign(n, 0);
  rows.degree.assign(n, 0);
#pragma omp parallel num_threads(num_threads)
  {
    std::vector<std::int64_t> lower(n, 0);  // this thread's counts, summed below: integers, in any order
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < n; ++i) {
      int count = 0;
      for (int c = 0; c < fog.count[i]; ++c) {
        const bool keep = kept(i, c);  // close to a coin toss on dense graphs
        count += keep;
        lower[fog.to[i][c]] += keep;
      }
      rows.count[i] = count;
    }
#pragma omp critical
    for (int v = 0; v < n; ++v) rows.degree[v] += lower[v];
  }
  for (int v = 0; v < n; ++v) rows.degree[v] += rows.count[v];
  CompatibilityGraph graph = graphWithDegrees(rows.degree);
  rows.to.assign(n, nullptr);
  rows.weight.assign(n, nullptr);
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads)
  for (int i = 0; i < n; ++i) {
    const std::int64_t tail = graph.offsets[i + 1] - rows.count[i];
    int* const to = graph.neighbours.data() + tail;
    float* const weight = graph.weights.data() + tail;
    // Each entry written at the next free slot, kept or not, and the slot taken only when it is kept;
    // the loop ends at the last kept one, so nothing is written past the tail.
    int written = 0;
    for (int c = 0; written < rows.count[i]; ++c) {
      to[written] = fog.to[i][c];
      weight[written] = fog.weight[i][c] * common[start[i] + c];
      written += kept(i, c);
    }
    rows.to[i] = to;
    rows.weight[i] = weight;
  }
  mirrorRows(rows, graph, num_threads);
  return graph;
}

float otsuThresholdOfSums(const UpperRows& fog, const EdgeSums& common, std::size_t& edges, int num_threads) {
  // otsuThreshold over the edges with a positive sum, in two parallel passes (extremes, then bins):
  // minima, maxima and integer counts are the same in any order.
  const int n = fog.numNodes();
  const std::vector<std::int64_t> start = fog.rowStarts();
  const float kInf = std::numeric_limits<float>::infinity();
  float lightest = kInf, heaviest = -kInf;
  std::int64_t count = 0;
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads) reduction(min : lightest) \
    reduction(max : heaviest) reduction(+ : count)
  for (int i = 0; i < n; ++i) {
    const float* const sum = common.data() + start[i];
    for (int c = 0; c < fog.count[i]; ++c) {
      const bool edge = sum[c] > 0.0f;
      const float w = fog.weight[i][c] * sum[c];
      count += edge;
      lightest = std::min(lightest, edge ? w : kInf);
      heaviest = std::max(heaviest, edge ? w : -kInf);
    }
  }
  edges = static_cast<std::size_t>(count);
  if (edges == 0) return 0.0f;
  const double low = lightest, span = double(heaviest) - low;
  if (!(span > 0.0)) return lightest;
  std::vector<std::int64_t> bins(kOtsuBins, 0);
#pragma omp parallel num_threads(num_threads)
  {
    std::vector<std::int64_t> local(kOtsuBins + 1, 0);  // the last one for the entries of no edge
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < n; ++i) {
      const float* const sum = common.data() + start[i];
      for (int c = 0; c < fog.count[i]; ++c) {
        const float w = fog.weight[i][c] * sum[c];
        ++local[sum[c] > 0.0f ? otsuBin(w, low, span) : kOtsuBins];
      }
    }
#pragma omp critical
    for (int b = 0; b < kOtsuBins; ++b) bins[b] += local[b];
  }
  return otsuCut(std::vector<double>(bins.begin(), bins.end()), double(edges), low, span);
}

double secondOrderWorkOfNodes(const CompatibilityGraph& graph, const std::vector<char>& keep, double limit,
                              int num_threads) {
  // secondOrderWork charges each upper edge (i, j) the degree of j: node j's share is its kept degree times
  // its kept lower neighbours, both read from its own list in one pass. Integers: exact in any order, and a
  // share alone above the limit puts the whole above it.
  std::int64_t work = 0;
  std::atomic<bool> over{false};
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : work) num_threads(num_threads)
  for (int j = 0; j < graph.num_nodes; ++j) {
    if (!keep[j] || over.load(std::memory_order_relaxed)) continue;
    std::int64_t kept = 0, lower = 0;
    for (auto p = graph.offsets[j]; p < graph.offsets[j + 1]; ++p) {
      const int i = graph.neighbours[p];
      const std::int64_t counted = keep[i] != 0;
      kept += counted;
      lower += counted & (i < j);
    }
    work += kept * lower;
    if (double(work) > limit) over = true;
  }
  return over || double(work) > limit ? std::numeric_limits<double>::infinity() : double(work);
}

CompatibilityGraph keepNodes(const CompatibilityGraph& graph, const std::vector<char>& keep,
                             int num_threads) {
  return filteredGraph(
      graph, [&](int i, std::int64_t p) { return keep[i] && keep[graph.neighbours[p]]; }, num_threads);
}

std::vector<char> strongestNodes(const std::vector<double>& score, std::size_t count) {
  std::vector<int> order(score.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return score[a] > score[b]; });
  std::vector<char> keep(score.size(), 0);
  for (std::size_t r = 0; r < std::min(count, order.size()); ++r) keep[order[r]] = 1;
  return keep;
}

float otsuEdgeThreshold(const CompatibilityGraph& graph) {
  // Each edge once, from its lower end: every count, sum and product is then exactly half (or a quarter)
  // of the one over both directions, and the cut is the same.
  return otsuThreshold(
      [&](auto visit) {
        for (int i = 0; i < graph.num_nodes; ++i) {
          for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) {
            if (graph.neighbours[p] > i) visit(graph.weights[p]);
          }
        }
      },
      graph.numEdges());
}

CompatibilityGraph withoutWeakEdges(const CompatibilityGraph& graph, float threshold, int num_threads) {
  return filteredGraph(
      graph, [&](int, std::int64_t p) { return graph.weights[p] >= threshold; }, num_threads);
}

std::vector<int> coreNumbers(const CompatibilityGraph& graph) {
  const int n = graph.num_nodes;
  std::vector<int> degree(n), order(n), position(n);
  int max_degree = 0;
  for (int i = 0; i < n; ++i) max_degree = std::max(max_degree, degree[i] = graph.degree(i));
  // Bucket sort by degree, then peel nodes in increasing degree, moving each neighbour one bucket down.
  std::vector<int> bucket_start(max_degree + 2, 0);
  for (int i = 0; i < n; ++i) ++bucket_start[degree[i] + 1];
  std::partial_sum(bucket_start.begin(), bucket_start.end(), bucket_start.begin());
  std::vector<int> next = bucket_start;
  for (int i = 0; i < n; ++i) {
    position[i] = next[degree[i]]++;
    order[position[i]] = i;
  }
  for (int k = 0; k < n; ++k) {
    const int v = order[k];
    for (auto p = graph.offsets[v]; p < graph.offsets[v + 1]; ++p) {
      const int u = graph.neighbours[p];
      if (degree[u] <= degree[v]) continue;
      // Swap u with the first node of its bucket, then shrink that bucket by one.
      const int first = order[bucket_start[degree[u]]];
      if (first != u) {
        std::swap(order[position[u]], order[bucket_start[degree[u]]]);
        std::swap(position[u], position[first]);
      }
      ++bucket_start[degree[u]];
      --degree[u];
    }
  }
  return degree;
}

std::vector<double> nodeStrength(const CompatibilityGraph& graph) {
  std::vector<double> strength(graph.num_nodes, 0.0);
  for (int i = 0; i < graph.num_nodes; ++i) {
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) strength[i] += graph.weights[p];
  }
  return strength;
}

}  // namespace mac_registration
