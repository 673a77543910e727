// Second-order weights of dense chance graphs estimated from common-neighbour counts (the exact sums are in
// compatibility_graph.cpp): bit rows of the neighbour sets, ANDed and counted a chunk of rows at a time.
#include <immintrin.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "mac_registration/core/compatibility_graph.hpp"

namespace mac_registration {
namespace {

// Neighbour sets of the nodes that have any, as bit rows over those nodes (position in `active`), each row
// padded to whole 512-bit blocks so that the AVX-512 count needs no tail.
struct NeighbourBits {
  std::vector<int> position;  // of each node among the active ones, -1 for isolated nodes
  std::size_t words = 0;      // 64-bit words per row, a multiple of 8
  UninitialisedVector<std::uint64_t> bits;

  const std::uint64_t* row(int node) const { return bits.data() + std::size_t(position[node]) * words; }
};

constexpr std::size_t kMaxNeighbourBitsBytes = std::size_t(64) << 20;

std::size_t activeNodes(const CompatibilityGraph& graph) {
  std::size_t active = 0;
  for (int i = 0; i < graph.num_nodes; ++i) active += graph.degree(i) > 0;
  return active;
}

std::size_t wordsPerRow(std::size_t active) { return (active + 511) / 512 * 8; }

// Each row is zeroed and filled by the thread that owns it, so that the pages are first touched there.
NeighbourBits neighbourBits(const CompatibilityGraph& graph, int num_threads) {
  NeighbourBits out;
  out.position.assign(graph.num_nodes, -1);
  int active = 0;
  for (int i = 0; i < graph.num_nodes; ++i) {
    if (graph.degree(i) > 0) out.position[i] = active++;
  }
  out.words = wordsPerRow(std::size_t(active));
  out.bits.resize(out.words * std::size_t(active));
#pragma omp parallel for schedule(dynamic, 64) num_threads(num_threads)
  for (int i = 0; i < graph.num_nodes; ++i) {
    if (out.position[i] < 0) continue;
    std::uint64_t* row = out.bits.data() + std::size_t(out.position[i]) * out.words;
    std::fill(row, row + out.words, std::uint64_t(0));
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) {
      const int k = out.position[graph.neighbours[p]];
      row[k >> 6] |= std::uint64_t(1) << (k & 63);
    }
  }
  return out;
}

__attribute__((target("avx512f,avx512vpopcntdq"))) std::int64_t commonCountAvx512(const std::uint64_t* a,
                                                                                  const std::uint64_t* b,
                                                                                  std::size_t words) {
  __m512i count = _mm512_setzero_si512();
  for (std::size_t w = 0; w < words; w += 8) {
    const __m512i both = _mm512_and_si512(_mm512_loadu_si512(a + w), _mm512_loadu_si512(b + w));
    count = _mm512_add_epi64(count, _mm512_popcnt_epi64(both));
  }
// GCC 12 warns of the undefined upper half that its _mm512_reduce_add_epi64 extracts into (a false
// positive, GCC bug 105593).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
  return _mm512_reduce_add_epi64(count);
#pragma GCC diagnostic pop
}

__attribute__((target_clones("popcnt", "default"))) std::int64_t commonCountPortable(const std::uint64_t* a,
                                                                                     const std::uint64_t* b,
                                                                                     std::size_t words) {
  std::int64_t count = 0;
  for (std::size_t w = 0; w < words; ++w) count += __builtin_popcountll(a[w] & b[w]);
  return count;
}

using CommonCount = std::int64_t (*)(const std::uint64_t*, const std::uint64_t*, std::size_t);

CommonCount commonCountForThisCpu() {
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vpopcntdq") ? commonCountAvx512
                                                                                        : commonCountPortable;
}

// Mean weight of each node's edges (0 for isolated nodes), each summed in double in list order: the same
// whatever the thread count.
std::vector<double> meanEdgeWeight(const CompatibilityGraph& graph, int num_threads) {
  std::vector<double> mean(graph.num_nodes, 0.0);
#pragma omp parallel for schedule(dynamic, 256) num_threads(num_threads)
  for (int i = 0; i < graph.num_nodes; ++i) {
    double sum = 0.0;
    for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p) sum += graph.weights[p];
    if (graph.degree(i) > 0) mean[i] = sum / graph.degree(i);
  }
  return mean;
}

}  // namespace

bool neighbourCountsFit(const CompatibilityGraph& graph) {
  const std::size_t active = activeNodes(graph);
  return double(active) * double(wordsPerRow(active)) * 8.0 <= double(kMaxNeighbourBitsBytes);
}

double countedSecondOrderWork(const CompatibilityGraph& graph) {
  return double(graph.numEdges()) * double(wordsPerRow(activeNodes(graph)));
}

EdgeSums countedCommonSums(const CompatibilityGraph& fog, int num_threads, const StopFlag* stop) {
  // The bit rows of all the nodes exceed L2 (640 bytes each at N = 5000, 3 MB in all), and a chance
  // graph's rows reach almost every node: rows are taken in chunks of kRowsPerChunk, and each chunk's
  // edges column block by column block, so that the chunk and one block stay cached (160 + 128 KB at
  // N = 5000) and each column row is fetched once per chunk, not once per edge.
  constexpr int kRowsPerChunk = 256;
  constexpr std::size_t kColumnBlockBytes = std::size_t(128) << 10;
  const int n = fog.num_nodes;
  const NeighbourBits bits = neighbourBits(fog, num_threads);
  const std::vector<double> mean = meanEdgeWeight(fog, num_threads);
  static const CommonCount count = commonCountForThisCpu();
  const int columns = static_cast<int>(
      std::max<std::size_t>(64, kColumnBlockBytes / (8 * std::max<std::size_t>(bits.words, 1))));
  EdgeSums common(fog.neighbours.size());  // every entry written below, on the threads
  const int chunks = (n + kRowsPerChunk - 1) / kRowsPerChunk;
#pragma omp parallel num_threads(num_threads)
  {
    std::int64_t cursor[kRowsPerChunk];
#pragma omp for schedule(dynamic, 1)
    for (int chunk = 0; chunk < chunks; ++chunk) {
      const int first = chunk * kRowsPerChunk, last = std::min(n, first + kRowsPerChunk);
      if (stopRequested(stop)) {  // incomplete, but never unwritten
        std::fill(common.begin() + fog.offsets[first], common.begin() + fog.offsets[last], 0.0f);
        continue;
      }
      for (int i = first; i < last; ++i) {  // the upper edges of i are the tail of its ascending list
        cursor[i - first] = std::upper_bound(fog.neighbours.begin() + fog.offsets[i],
                                             fog.neighbours.begin() + fog.offsets[i + 1], i) -
                            fog.neighbours.begin();
        std::fill(common.begin() + fog.offsets[i], common.begin() + cursor[i - first], 0.0f);
      }
      for (int block_end = (first / columns + 1) * columns;; block_end += columns) {
        bool more = false;
        for (int i = first; i < last; ++i) {
          std::int64_t& p = cursor[i - first];
          const std::int64_t end = fog.offsets[i + 1];
          for (; p < end && fog.neighbours[p] < block_end; ++p) {
            const int j = fog.neighbours[p];
            const std::int64_t shared = count(bits.row(i), bits.row(j), bits.words);
            common[p] = static_cast<float>(double(shared) * mean[i] * mean[j]);
          }
          more = more || p < end;
        }
        if (!more) break;
      }
    }
  }
  return common;
}

CompatibilityGraph buildCountedSecondOrderGraph(const CompatibilityGraph& fog, int num_threads,
                                                const StopFlag* stop) {
  return triangleEdgesFromSums(fog, countedCommonSums(fog, num_threads, stop), 0.0f, num_threads);
}

}  // namespace mac_registration
