// The first-order compatibility graph (FOG): the O(N^2) pair test, its bounds, and the graph's assembly.
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

#include "compatibility_graph.hpp"
#include "graph_assembly.hpp"
#include "graph_bounds.hpp"
#include "kernels/kernel_table.hpp"

namespace mac_registration {
namespace {

// Largest d^2 whose score still reaches t_cmp; both scores fall monotonically with d.
double maxResidualSquared(const GraphParams& params) {
  if (params.score == CompatibilityScore::kGaussian) {
    return -2.0 * params.gaussian_sigma * params.gaussian_sigma * std::log(params.t_cmp);
  }
  return (1.0 - params.t_cmp) * params.quadratic_threshold * params.quadratic_threshold;
}

float scoreFromResidualSquared(float d2, const GraphParams& params) {
  if (params.score == CompatibilityScore::kGaussian) {
    return std::exp(-d2 / static_cast<float>(2.0 * params.gaussian_sigma * params.gaussian_sigma));
  }
  return 1.0f - d2 / static_cast<float>(params.quadratic_threshold * params.quadratic_threshold);
}

// Structure-of-arrays float copy of some correspondences, centred on each cloud's centroid (of all the
// correspondences) so that float keeps millimetres even for map-sized coordinates; the loops over it
// vectorize. Each array starts on a cache line.
class PointsSoA {
 public:
  float *sx = nullptr, *sy = nullptr, *sz = nullptr, *tx = nullptr, *ty = nullptr, *tz = nullptr;

  PointsSoA(const CorrespondenceSet& c, const std::vector<int>& nodes) {
    allocate(nodes.size());
    const Eigen::Vector3d s0 = c.source_points.rowwise().mean();
    const Eigen::Vector3d t0 = c.target_points.rowwise().mean();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const Eigen::Vector3d s = c.source_points.col(nodes[k]) - s0;
      const Eigen::Vector3d t = c.target_points.col(nodes[k]) - t0;
      sx[k] = float(s.x()), sy[k] = float(s.y()), sz[k] = float(s.z());
      tx[k] = float(t.x()), ty[k] = float(t.y()), tz[k] = float(t.z());
    }
  }

  // The points `subset` of `from`, the same floats: a pair tests the same in both.
  PointsSoA(const PointsSoA& from, const std::vector<int>& subset) {
    allocate(subset.size());
    for (std::size_t k = 0; k < subset.size(); ++k) {
      const int i = subset[k];
      sx[k] = from.sx[i], sy[k] = from.sy[i], sz[k] = from.sz[i];
      tx[k] = from.tx[i], ty[k] = from.ty[i], tz[k] = from.tz[i];
    }
  }

  PointsSoA(const PointsSoA&) = delete;  // the arrays point into storage_
  PointsSoA& operator=(const PointsSoA&) = delete;

  int size() const { return size_; }

  // The pairs (i, j > i) with d^2 <= max_d2: their j ascending in candidates, their d^2 in candidate_d2;
  // returns how many. `scratch` holds size() floats.
  int compatibleInRow(int i, float max_d2, float* scratch, int* candidates, float* candidate_d2) const {
    static const kernels::PairTest kernel = kernels::activeKernels().pair_test.run;
    return kernel(sx, sy, sz, tx, ty, tz, i, size(), max_d2, scratch, candidates, candidate_d2);
  }

 private:
  void allocate(std::size_t n) {
    constexpr std::size_t kLineFloats = kCacheLineBytes / sizeof(float);
    const std::size_t stride = (n + kLineFloats - 1) / kLineFloats * kLineFloats;
    storage_.resize(6 * stride + kLineFloats - 1);
    float* first = firstOnCacheLine(storage_.data());
    float** arrays[] = {&sx, &sy, &sz, &tx, &ty, &tz};
    for (std::size_t a = 0; a < 6; ++a) *arrays[a] = first + a * stride;
    size_ = static_cast<int>(n);
  }

  UninitialisedVector<float> storage_;
  int size_ = 0;
};

// Rows written back to back, each whole in one chunk; chunks are allocated uninitialised and never moved,
// so that growing neither zero-fills nor copies what is written.
class RowChunks {
 public:
  explicit RowChunks(std::size_t chunk_entries) : chunk_entries_(chunk_entries) {}

  // Room for `entries` more at to() and weight(), in the current chunk or a new one.
  void reserve(std::size_t entries) {
    if (!to_.empty() && used_ + entries <= capacity_) return;
    capacity_ = std::max(chunk_entries_, entries);
    to_.emplace_back(new int[capacity_]);
    weight_.emplace_back(new float[capacity_]);
    used_ = 0;
  }
  int* to() { return to_.back().get() + used_; }
  float* weight() { return weight_.back().get() + used_; }
  void commit(std::size_t entries) { used_ += entries; }

 private:
  std::size_t chunk_entries_, capacity_ = 0, used_ = 0;
  std::vector<std::unique_ptr<int[]>> to_;
  std::vector<std::unique_ptr<float[]>> weight_;
};

// One pass over every pair of a point set. Each thread appends the rows it tests to chunks of its own, so
// that no row needs an allocation of its own.
struct PairPass {
  std::vector<RowChunks> chunks;   // per thread: the rows it kept
  std::vector<int*> row_to;        // row i's j, ascending, in its thread's chunks
  std::vector<float*> row_weight;  // their weights
  std::vector<int> row_count;      // entries of row i kept (all of them, or 0 past max_edges)
  std::vector<int> degree;         // compatible pairs of each point, all of them counted
  std::size_t compatible = 0;      // compatible pairs in all
  bool within_max_edges = true;    // compatible <= max_edges, and so the rows are complete
};

// Tests every pair, counting each point's compatible pairs, and keeps the edges while there are at most
// max_edges of them (memory stays bounded past that; the count goes on, so that a reduction can rank
// nodes by their true degree). Counts and the outcome are the same whatever the thread count. A raised
// stop leaves everything incomplete, but the rows kept and the degrees still agree.
PairPass compatiblePairs(const PointsSoA& points, const GraphParams& params, std::size_t max_edges,
                         int num_threads, const StopFlag* stop) {
  const int n = points.size();
  const float max_d2 = static_cast<float>(maxResidualSquared(params));
  // 64 kB chunks (of at least a row): below glibc's mmap threshold, so that they come from the heap and,
  // freed, stay there for the next graph instead of being mapped afresh, page by page, each time.
  constexpr std::size_t kChunkEntries = std::size_t(1) << 14;
  PairPass pass;
  for (int t = 0; t < num_threads; ++t)
    pass.chunks.emplace_back(std::max(kChunkEntries, n + kernels::kPairTestSlack));
  pass.row_to.assign(n, nullptr);
  pass.row_weight.assign(n, nullptr);
  pass.row_count.assign(n, 0);
  pass.degree.assign(n, 0);
  std::atomic<std::size_t> total{0};
  std::atomic<bool> overflow{false};
#pragma omp parallel num_threads(num_threads)
  {
    RowChunks& chunks = pass.chunks[omp_get_thread_num()];
    std::vector<float> d2(n);
    std::vector<int> degree(n, 0);  // this thread's counts, summed below: integers, so in any order
#pragma omp for schedule(dynamic, 16)
    for (int i = 0; i < n; ++i) {
      if (stopRequested(stop)) continue;
      // The kernel writes the found pairs straight into place, their d^2 where their weights go.
      chunks.reserve(static_cast<std::size_t>(n - i - 1) + kernels::kPairTestSlack);
      int* const to = chunks.to();
      float* const weight = chunks.weight();
      const int found = points.compatibleInRow(i, max_d2, d2.data(), to, weight);
      degree[i] += found;
      for (int c = 0; c < found; ++c) ++degree[to[c]];
      if (total.fetch_add(found) + found > max_edges) overflow = true;
      if (overflow.load(std::memory_order_relaxed)) continue;
      for (int c = 0; c < found; ++c) weight[c] = scoreFromResidualSquared(weight[c], params);
      pass.row_to[i] = to;
      pass.row_weight[i] = weight;
      pass.row_count[i] = found;
      chunks.commit(static_cast<std::size_t>(found));
    }
#pragma omp critical
    for (int i = 0; i < n; ++i) pass.degree[i] += degree[i];
  }
  pass.compatible = total;
  pass.within_max_edges = !overflow;
  if (overflow) {
    std::vector<RowChunks>().swap(pass.chunks);
    pass.row_to.assign(n, nullptr);
    pass.row_weight.assign(n, nullptr);
    pass.row_count.assign(n, 0);
  }
  return pass;
}

// The rows of `pass`, whose point k is node node_of_point[k] of a graph of num_nodes (ascending, so the
// rows stay ascending); relabels the pass's entries in place. Where the pass kept its rows, its degrees are
// their counts at both ends.
UpperRows nodeRowsOf(PairPass& pass, const std::vector<int>& node_of_point, int num_nodes, int num_threads) {
  UpperRows rows;
  rows.to.assign(num_nodes, nullptr);
  rows.weight.assign(num_nodes, nullptr);
  rows.count.assign(num_nodes, 0);
  rows.degree.assign(num_nodes, 0);
  const int points = static_cast<int>(node_of_point.size());
  bool identity = true;
  for (int k = 0; k < points && identity; ++k) identity = node_of_point[k] == k;
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads)
  for (int k = 0; k < points; ++k) {
    const int node = node_of_point[k];
    int* to = pass.row_to[k];
    if (!identity) {
      for (int c = 0; c < pass.row_count[k]; ++c) to[c] = node_of_point[to[c]];
    }
    rows.to[node] = to;
    rows.weight[node] = pass.row_weight[k];
    rows.count[node] = pass.row_count[k];
    rows.degree[node] = pass.within_max_edges ? pass.degree[k] : 0;
  }
  return rows;
}

// secondOrderWorkOfNodes of that graph, read from the rows; +infinity once past `limit`. Node j's share is
// its kept degree times its kept lower neighbours. Rows are read in ascending order, so when row j comes,
// every row that names j has been read and j's share is known: the sum can stop as soon as it passes the
// limit, which every round but the last does early. Integers: exact.
double secondOrderWorkOfKeptRows(const PairPass& pass, const std::vector<char>& keep, double limit) {
  const int n = static_cast<int>(keep.size());
  std::vector<std::int64_t> lower(n, 0);
  std::int64_t work = 0;
  for (int j = 0; j < n; ++j) {
    if (!keep[j]) continue;
    std::int64_t upper = 0;
    const int* const to = pass.row_to[j];
    for (int c = 0; c < pass.row_count[j]; ++c) {  // branch-free: about half the entries are kept
      const std::int64_t kept = keep[to[c]] != 0;
      upper += kept;
      lower[to[c]] += kept;
    }
    work += (lower[j] + upper) * lower[j];
    if (double(work) > limit) return std::numeric_limits<double>::infinity();
  }
  return double(work);
}

// Leaves in the pass's rows only the pairs among kept points, in place, and recounts the degrees: the
// rows keepNodes would leave of the graph.
void keepRowsOf(PairPass& pass, const std::vector<char>& keep) {
  const int n = static_cast<int>(keep.size());
  std::fill(pass.degree.begin(), pass.degree.end(), 0);
  for (int i = 0; i < n; ++i) {
    int kept = 0;
    if (keep[i]) {
      for (int c = 0; c < pass.row_count[i]; ++c) {
        const int j = pass.row_to[i][c];
        if (!keep[j]) continue;
        pass.row_to[i][kept] = j;
        pass.row_weight[i][kept] = pass.row_weight[i][c];
        ++kept;
        ++pass.degree[j];
      }
    }
    pass.row_count[i] = kept;
    pass.degree[i] += kept;
  }
}

// What the second-order budget would do to the graph of the pass (the tests' boundSecondOrderWork, on its
// lists), done to its rows before any list is built: a dense consensus makes a first-order graph of millions
// of edges that the budget then cuts to a few hundred nodes, and building those lists first cost more than
// the rest of the registration.
void boundPassSecondOrderWork(PairPass& pass, double budget, const StopFlag* stop, FirstOrderBounds& result) {
  if (budget <= 0.0 || !pass.within_max_edges ||
      secondOrderWorkOfDegrees(pass.degree, pass.row_count) <= budget)
    return;
  const std::vector<double> degree(pass.degree.begin(), pass.degree.end());
  std::size_t edges = 0;
  for (const int count : pass.row_count) edges += static_cast<std::size_t>(count);
  const std::vector<char> keep = nodesWithinSecondOrderBudget(
      degree, budget,
      [&](const std::vector<char>& kept) { return secondOrderWorkOfKeptRows(pass, kept, budget); }, stop,
      result.second_order_kept_nodes);
  keepRowsOf(pass, keep);
  std::size_t kept_edges = 0;
  for (const int count : pass.row_count) kept_edges += static_cast<std::size_t>(count);
  result.second_order_bounded = true;
  result.second_order_removed_edges = edges - kept_edges;
}

// `count` indices spread evenly over [0, n), ascending; all of them when count >= n.
std::vector<int> evenlySpaced(int n, std::size_t count) {
  const auto m = static_cast<long long>(std::min<std::size_t>(count, static_cast<std::size_t>(n)));
  std::vector<int> picked(m);
  for (long long k = 0; k < m; ++k) picked[k] = static_cast<int>(k * n / m);
  return picked;
}

std::vector<int> indicesOf(const std::vector<char>& mask) {
  std::vector<int> indices;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (mask[i]) indices.push_back(static_cast<int>(i));
  }
  return indices;
}

}  // namespace

FirstOrderRows firstOrderRows(const CorrespondenceSet& correspondences, const GraphParams& params,
                              int num_threads, const StopFlag* stop, double second_order_budget) {
  const int n = static_cast<int>(correspondences.size());
  FirstOrderRows result;
  const auto no_edges = [&result](int nodes) {
    result.rows = UpperRows();
    result.rows.to.assign(nodes, nullptr);
    result.rows.weight.assign(nodes, nullptr);
    result.rows.count.assign(nodes, 0);
    result.rows.degree.assign(nodes, 0);
    return result;
  };
  if (n == 0) return no_edges(0);
  // The pass is O(N^2): above max_correspondences it runs on an evenly spaced subset, which keeps the
  // inlier ratio of the whole set and bounds the time whatever N.
  const std::size_t cap = params.max_correspondences > 0 ? params.max_correspondences : std::size_t(n);
  const std::vector<int> nodes = evenlySpaced(n, cap);
  result.sampled = nodes.size() < std::size_t(n);
  result.sampled_to = nodes.size();
  const PointsSoA points(correspondences, nodes);
  auto pass =
      std::make_shared<PairPass>(compatiblePairs(points, params, params.max_edges, num_threads, stop));
  result.compatible_pairs = pass->compatible;
  if (stopRequested(stop)) {
    result.cancelled = true;
    return no_edges(n);
  }
  if (pass->within_max_edges) {
    boundPassSecondOrderWork(*pass, second_order_budget, stop, result);
    result.rows = nodeRowsOf(*pass, nodes, n, num_threads);
    result.buffers = std::move(pass);
    return result;
  }
  // Too dense to hold: keep the nodes of highest degree, few enough that even a complete graph on them
  // fits the bound. Inliers of a consensus have the highest degree, so they are what is kept.
  const auto keep_count = static_cast<std::size_t>(std::sqrt(2.0 * static_cast<double>(params.max_edges)));
  const std::vector<int> kept =
      indicesOf(strongestNodes(std::vector<double>(pass->degree.begin(), pass->degree.end()), keep_count));
  pass.reset();
  std::vector<int> kept_nodes(kept.size());
  for (std::size_t k = 0; k < kept.size(); ++k) kept_nodes[k] = nodes[kept[k]];
  auto dense = std::make_shared<PairPass>(
      compatiblePairs(PointsSoA(points, kept), params, params.max_edges, num_threads, stop));
  boundPassSecondOrderWork(*dense, second_order_budget, stop, result);
  result.reduced = true;
  result.reduced_to = kept.size();
  result.cancelled = stopRequested(stop);
  result.rows = nodeRowsOf(*dense, kept_nodes, n, num_threads);
  result.buffers = std::move(dense);
  return result;
}

}  // namespace mac_registration
