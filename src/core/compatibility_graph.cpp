#include "mac_registration/core/compatibility_graph.hpp"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>

#include <omp.h>

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

// The O(N^2) loop of the graph: branch-free so that it vectorizes, with an AVX2 clone picked at run time
// where the CPU has it (the same IEEE operations, no FMA, so the same edges either way).
__attribute__((target_clones("avx2", "default"))) void pairResidualsSquared(const float* sx, const float* sy,
                                                                            const float* sz, const float* tx,
                                                                            const float* ty, const float* tz,
                                                                            int i, int begin, int end,
                                                                            float* out) {
  const float six = sx[i], siy = sy[i], siz = sz[i], tix = tx[i], tiy = ty[i], tiz = tz[i];
  for (int j = begin; j < end; ++j) {
    const float ds = std::sqrt((six - sx[j]) * (six - sx[j]) + (siy - sy[j]) * (siy - sy[j]) +
                               (siz - sz[j]) * (siz - sz[j]));
    const float dt = std::sqrt((tix - tx[j]) * (tix - tx[j]) + (tiy - ty[j]) * (tiy - ty[j]) +
                               (tiz - tz[j]) * (tiz - tz[j]));
    out[j - begin] = (ds - dt) * (ds - dt);
  }
}

// The pairs (i, j > i) of one row that pass the test d^2 <= max_d2, compacted: candidates[c] = j and
// candidate_d2[c] = d^2 for the found ones, ascending in j; returns how many. `d2` is scratch of n floats.
// Branch-free compaction: almost every pair fails the test, so a branch per pair mispredicts.
int compatibleInRowPortable(const float* sx, const float* sy, const float* sz, const float* tx,
                            const float* ty, const float* tz, int i, int n, float max_d2, float* d2,
                            int* candidates, float* candidate_d2) {
  pairResidualsSquared(sx, sy, sz, tx, ty, tz, i, i + 1, n, d2);
  int found = 0;
  for (int j = i + 1; j < n; ++j) {
    candidates[found] = j;
    candidate_d2[found] = d2[j - i - 1];
    found += d2[j - i - 1] <= max_d2;
  }
  return found;
}

// |p_i - p_j| for the valid ones of the sixteen points from j, as pairResidualsSquared computes it.
__attribute__((target("avx512f"), optimize("fp-contract=off"))) inline __m512 distances16(
    const float* x, const float* y, const float* z, int j, __mmask16 valid, __m512 xi, __m512 yi, __m512 zi) {
  const __m512 dx = _mm512_sub_ps(xi, _mm512_maskz_loadu_ps(valid, x + j));
  const __m512 dy = _mm512_sub_ps(yi, _mm512_maskz_loadu_ps(valid, y + j));
  const __m512 dz = _mm512_sub_ps(zi, _mm512_maskz_loadu_ps(valid, z + j));
  return _mm512_maskz_sqrt_ps(
      valid,
      _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz)));
}

// The same with AVX-512: sixteen pairs at a time, the test's mask compressing the passing ones straight
// into place. The same IEEE operations in the same order as pairResidualsSquared, so the same pairs and d^2
// bit for bit: AVX-512 has FMA, and contracting a multiply and an add into one would round differently.
__attribute__((target("avx512f,popcnt"), optimize("fp-contract=off"))) int compatibleInRowAvx512(
    const float* sx, const float* sy, const float* sz, const float* tx, const float* ty, const float* tz,
    int i, int n, float max_d2, float*, int* candidates, float* candidate_d2) {
  const __m512 six = _mm512_set1_ps(sx[i]), siy = _mm512_set1_ps(sy[i]), siz = _mm512_set1_ps(sz[i]);
  const __m512 tix = _mm512_set1_ps(tx[i]), tiy = _mm512_set1_ps(ty[i]), tiz = _mm512_set1_ps(tz[i]);
  const __m512 bound = _mm512_set1_ps(max_d2);
  const __m512i step = _mm512_set1_epi32(16);
  __m512i index = _mm512_add_epi32(_mm512_set1_epi32(i + 1),
                                   _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
  int found = 0;
  for (int j = i + 1; j < n; j += 16) {
    const __mmask16 valid = n - j >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (n - j)) - 1u);
    const __m512 difference = _mm512_sub_ps(distances16(sx, sy, sz, j, valid, six, siy, siz),
                                            distances16(tx, ty, tz, j, valid, tix, tiy, tiz));
    const __m512 d2 = _mm512_mul_ps(difference, difference);
    const __mmask16 pass = _mm512_mask_cmp_ps_mask(valid, d2, bound, _CMP_LE_OQ);
    _mm512_mask_compressstoreu_epi32(candidates + found, pass, index);
    _mm512_mask_compressstoreu_ps(candidate_d2 + found, pass, d2);
    found += __builtin_popcount(pass);
    index = _mm512_add_epi32(index, step);
  }
  return found;
}

using CompatibleInRow = int (*)(const float*, const float*, const float*, const float*, const float*,
                                const float*, int, int, float, float*, int*, float*);

CompatibleInRow compatibleInRowForThisCpu() {
  return __builtin_cpu_supports("avx512f") ? compatibleInRowAvx512 : compatibleInRowPortable;
}

// Structure-of-arrays float copy of some correspondences, centred on each cloud's centroid (of all the
// correspondences) so that float keeps millimetres even for map-sized coordinates; the loops over it
// vectorize.
struct PointsSoA {
  std::vector<float> sx, sy, sz, tx, ty, tz;

  PointsSoA(const CorrespondenceSet& c, const std::vector<int>& nodes) {
    const Eigen::Vector3d s0 = c.source_points.rowwise().mean();
    const Eigen::Vector3d t0 = c.target_points.rowwise().mean();
    resize(nodes.size());
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const Eigen::Vector3d s = c.source_points.col(nodes[k]) - s0;
      const Eigen::Vector3d t = c.target_points.col(nodes[k]) - t0;
      sx[k] = float(s.x()), sy[k] = float(s.y()), sz[k] = float(s.z());
      tx[k] = float(t.x()), ty[k] = float(t.y()), tz[k] = float(t.z());
    }
  }

  // The points `subset` of `from`, the same floats: a pair tests the same in both.
  PointsSoA(const PointsSoA& from, const std::vector<int>& subset) {
    resize(subset.size());
    for (std::size_t k = 0; k < subset.size(); ++k) {
      const int i = subset[k];
      sx[k] = from.sx[i], sy[k] = from.sy[i], sz[k] = from.sz[i];
      tx[k] = from.tx[i], ty[k] = from.ty[i], tz[k] = from.tz[i];
    }
  }

  int size() const { return static_cast<int>(sx.size()); }

  // The pairs (i, j > i) with d^2 <= max_d2: their j ascending in candidates, their d^2 in candidate_d2;
  // returns how many. `scratch` holds size() floats.
  int compatibleInRow(int i, float max_d2, float* scratch, int* candidates, float* candidate_d2) const {
    static const CompatibleInRow kernel = compatibleInRowForThisCpu();
    return kernel(sx.data(), sy.data(), sz.data(), tx.data(), ty.data(), tz.data(), i, size(), max_d2,
                  scratch, candidates, candidate_d2);
  }

 private:
  void resize(std::size_t n) {
    for (auto* v : {&sx, &sy, &sz, &tx, &ty, &tz}) v->resize(n);
  }
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
  for (int t = 0; t < num_threads; ++t) pass.chunks.emplace_back(std::max(kChunkEntries, std::size_t(n)));
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
      chunks.reserve(static_cast<std::size_t>(n - i - 1));
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

// The rows of the graph's nodes as spans of a pass's buffers: each ascending, above its node.
struct NodeRows {
  std::vector<const int*> to;
  std::vector<const float*> weight;
  std::vector<int> count;
  std::vector<std::int64_t> degree;  // the node's whole degree: its row and the rows that name it
};

// The rows of `pass`, whose point k is node node_of_point[k] of a graph of num_nodes (ascending, so the
// rows stay ascending); relabels the pass's entries in place. Where the pass kept its rows, its degrees are
// their counts at both ends.
NodeRows nodeRowsOf(PairPass& pass, const std::vector<int>& node_of_point, int num_nodes, int num_threads) {
  NodeRows rows;
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

// A graph whose node v has degree[v] neighbours: its offsets, and its lists allocated.
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

// Writes the lower entries of every list of `graph` (the rows that name its node, before its own row at
// the tail): the nodes are split into one range per thread by equal shares of lower entries, each thread
// walking all the rows from a binary search to its range, in ascending row order, so that every list
// comes out ascending without a sort; and in blocks of nodes, so that the lines being written stay cached.
// The rows may be the graph's own tails.
void mirrorRows(const NodeRows& rows, CompatibilityGraph& graph, int num_threads) {
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

// graphFromUpperRows on num_threads threads, the same graph bit for bit: each row copied to the tail of
// its node's list, then mirrored to the lower entries.
CompatibilityGraph graphFromNodeRows(const NodeRows& rows, int num_threads) {
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

// Sum over j's list, in its ascending order, of row[k] * S_jk: with row = i's weights scattered densely (0
// off i's list, and adding +0 changes no float) this is the common-neighbour sum of edge (i, j).
float listSum(const CompatibilityGraph& fog, const float* row, int j) {
  float sum = 0.0f;
  for (auto q = fog.offsets[j]; q < fog.offsets[j + 1]; ++q) sum += row[fog.neighbours[q]] * fog.weights[q];
  return sum;
}

// out[p] = listSum(fog, row, j) for every first-order edge (i, j) at list position p in [first, last).
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
        out[slot[l]] = sum[l];
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
      out[slot[l]] = rest;
    }
  }
  for (; next < last; ++next) out[next] = listSum(fog, row, neighbours[next]);
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

// First position of node i's upper neighbours (j > i): the tail of its ascending list.
std::int64_t upperBegin(const CompatibilityGraph& graph, int i) {
  return std::upper_bound(graph.neighbours.begin() + graph.offsets[i],
                          graph.neighbours.begin() + graph.offsets[i + 1], i) -
         graph.neighbours.begin();
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

// upperBegin of every node.
std::vector<std::int64_t> upperBegins(const CompatibilityGraph& graph, int num_threads) {
  std::vector<std::int64_t> begins(graph.num_nodes);
#pragma omp parallel for schedule(static) num_threads(num_threads)
  for (int i = 0; i < graph.num_nodes; ++i) begins[i] = upperBegin(graph, i);
  return begins;
}

}  // namespace

float CompatibilityGraph::weight(int a, int b) const {
  const auto first = neighbours.begin() + offsets[a];
  const auto last = neighbours.begin() + offsets[a + 1];
  const auto it = std::lower_bound(first, last, b);
  return (it != last && *it == b) ? weights[it - neighbours.begin()] : 0.0f;
}

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
                                     int num_threads, const StopFlag* stop) {
  const int n = static_cast<int>(correspondences.size());
  FirstOrderGraph result;
  if (n == 0) {
    result.graph = graphFromUpperRows(0, {});
    return result;
  }
  // The pass is O(N^2): above max_correspondences it runs on an evenly spaced subset, which keeps the
  // inlier ratio of the whole set and bounds the time whatever N.
  const std::size_t cap = params.max_correspondences > 0 ? params.max_correspondences : std::size_t(n);
  const std::vector<int> nodes = evenlySpaced(n, cap);
  result.sampled = nodes.size() < std::size_t(n);
  result.sampled_to = nodes.size();
  const PointsSoA points(correspondences, nodes);
  PairPass pass = compatiblePairs(points, params, params.max_edges, num_threads, stop);
  result.compatible_pairs = pass.compatible;
  if (stopRequested(stop)) {
    result.cancelled = true;
    result.graph = graphFromUpperRows(n, std::vector<std::vector<UpperEdge>>(n));
    return result;
  }
  if (pass.within_max_edges) {
    result.graph = graphFromNodeRows(nodeRowsOf(pass, nodes, n, num_threads), num_threads);
    return result;
  }
  // Too dense to hold: keep the nodes of highest degree, few enough that even a complete graph on them
  // fits the bound. Inliers of a consensus have the highest degree, so they are what is kept.
  const auto keep_count = static_cast<std::size_t>(std::sqrt(2.0 * static_cast<double>(params.max_edges)));
  const std::vector<int> kept =
      indicesOf(strongestNodes(std::vector<double>(pass.degree.begin(), pass.degree.end()), keep_count));
  std::vector<int> kept_nodes(kept.size());
  for (std::size_t k = 0; k < kept.size(); ++k) kept_nodes[k] = nodes[kept[k]];
  PairPass dense = compatiblePairs(PointsSoA(points, kept), params, params.max_edges, num_threads, stop);
  result.reduced = true;
  result.reduced_to = kept.size();
  result.cancelled = stopRequested(stop);
  result.graph = graphFromNodeRows(nodeRowsOf(dense, kept_nodes, n, num_threads), num_threads);
  return result;
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

CompatibilityGraph buildSecondOrderGraph(const CompatibilityGraph& fog, int num_threads,
                                         const StopFlag* stop) {
  const int n = fog.num_nodes;
  // Common-neighbour sum of each upper edge, at its position in the first-order lists (0 elsewhere).
  std::vector<float> common(fog.neighbours.size(), 0.0f);
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
      // The upper edges of i are the tail of its ascending list.
      const auto upper = std::upper_bound(fog.neighbours.begin() + begin, fog.neighbours.begin() + end, i) -
                         fog.neighbours.begin();
      commonNeighbourSums(fog, row_i.data(), upper, end, common.data());
      for (auto p = begin; p < end; ++p) row_i[fog.neighbours[p]] = 0.0f;
    }
  }
  return triangleEdgesFromSums(fog, common, 0.0f, num_threads);
}

CompatibilityGraph triangleEdgesFromSums(const CompatibilityGraph& fog, const std::vector<float>& common,
                                         float min_weight, int num_threads) {
  // The kept upper entries of each first-order row are its node's row in the graph: counted first (at
  // both ends, for the offsets), then compacted straight into the tails of the lists and mirrored from
  // there, as graphFromNodeRows does.
  const int n = fog.num_nodes;
  const std::vector<std::int64_t> upper_begin = upperBegins(fog, num_threads);
  const auto kept = [&](std::int64_t p) {
    return (common[p] > 0.0f) & (fog.weights[p] * common[p] >= min_weight);  // both: no branch
  };
  NodeRows rows;
  rows.count.assign(n, 0);
  rows.degree.assign(n, 0);
#pragma omp parallel num_threads(num_threads)
  {
    std::vector<std::int64_t> lower(n, 0);  // this thread's counts, summed below: integers, in any order
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < n; ++i) {
      int count = 0;
      for (auto p = upper_begin[i]; p < fog.offsets[i + 1]; ++p) {
        const bool keep = kept(p);  // close to a coin toss on dense graphs
        count += keep;
        lower[fog.neighbours[p]] += keep;
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
    for (auto p = upper_begin[i]; written < rows.count[i]; ++p) {
      to[written] = fog.neighbours[p];
      weight[written] = fog.weights[p] * common[p];
      written += kept(p);
    }
    rows.to[i] = to;
    rows.weight[i] = weight;
  }
  mirrorRows(rows, graph, num_threads);
  return graph;
}

float otsuThresholdOfSums(const CompatibilityGraph& fog, const std::vector<float>& common, std::size_t& edges,
                          int num_threads) {
  // otsuThreshold over the edges with a positive sum, in two parallel passes (extremes, then bins):
  // minima, maxima and integer counts are the same in any order.
  const int n = fog.num_nodes;
  const std::vector<std::int64_t> upper_begin = upperBegins(fog, num_threads);
  const float kInf = std::numeric_limits<float>::infinity();
  float lightest = kInf, heaviest = -kInf;
  std::int64_t count = 0;
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads) reduction(min : lightest) \
    reduction(max : heaviest) reduction(+ : count)
  for (int i = 0; i < n; ++i) {
    for (auto p = upper_begin[i]; p < fog.offsets[i + 1]; ++p) {
      const bool edge = common[p] > 0.0f;
      const float w = fog.weights[p] * common[p];
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
      for (auto p = upper_begin[i]; p < fog.offsets[i + 1]; ++p) {
        const float w = fog.weights[p] * common[p];
        ++local[common[p] > 0.0f ? otsuBin(w, low, span) : kOtsuBins];
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
