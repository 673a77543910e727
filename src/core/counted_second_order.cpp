// Second-order weights of dense chance graphs estimated from common-neighbour counts (the exact sums are in
// compatibility_graph.cpp): bit rows of the neighbour sets, ANDed and counted a chunk of rows at a time.
#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <vector>

#include "compatibility_graph.hpp"
#include "kernels/kernel_table.hpp"

namespace mac_registration {
namespace {

// Neighbour sets of the nodes that have any, as bit rows over those nodes (position in `active`), each row
// padded to whole 512-bit blocks so that the AVX-512 count needs no tail, and starting on a cache line: a
// 512-bit load across two lines costs two, and the count is mostly loads.
struct NeighbourBits {
  std::vector<int> position;  // of each node among the active ones, -1 for isolated nodes
  std::size_t words = 0;      // 64-bit words per row, a multiple of 8
  UninitialisedVector<std::uint64_t> storage;
  std::uint64_t* first = nullptr;  // the first row, 64-byte aligned in storage

  void allocate(std::size_t rows) {
    storage.resize(rows * words + kCacheLineBytes / sizeof(std::uint64_t) - 1);
    first = firstOnCacheLine(storage.data());
  }
  std::uint64_t* row(int node) const { return first + std::size_t(position[node]) * words; }
  std::uint64_t& word(int row_position, std::size_t w) const { return first[row_position * words + w]; }
  void set(int node, int neighbour) const {
    const int k = position[neighbour];
    row(node)[k >> 6] |= std::uint64_t(1) << (k & 63);
  }
};

constexpr std::size_t kMaxNeighbourBitsBytes = std::size_t(64) << 20;

std::size_t activeNodes(const UpperRows& rows) {
  std::size_t active = 0;
  for (const std::int64_t d : rows.degree) active += d > 0;
  return active;
}

std::size_t wordsPerRow(std::size_t active) { return (active + 511) / 512 * 8; }

// Gives every bit row its lower bits, the transpose of the upper ones that its own rows set: block
// (r, c) of 64 x 64 bits, above the diagonal, is ORed transposed into block (c, r). Each thread writes the
// lower blocks of its own block rows and reads only upper blocks, which no thread writes here.
void mirrorUpperBits(NeighbourBits& bits, int active, int num_threads) {
  static const kernels::TransposeBits transposeBits = kernels::activeKernels().transpose_bits.run;
  const int blocks = (active + 63) / 64;
#pragma omp parallel for schedule(dynamic, 1) num_threads(num_threads)
  for (int c = 0; c < blocks; ++c) {
    const int rows_c = std::min(64, active - 64 * c);
    for (int r = 0; r <= c; ++r) {
      const int rows_r = std::min(64, active - 64 * r);
      std::uint64_t block[64] = {};
      for (int k = 0; k < rows_r; ++k) block[k] = bits.word(64 * r + k, c);
      transposeBits(block);
      for (int k = 0; k < rows_c; ++k) bits.word(64 * c + k, r) |= block[k];
    }
  }
}

// Weights as integers of kWeightScale: a node's sum of them is exact, and so the same in any order, for
// weights of 2^-16 or more (every first-order weight is at least t_cmp) and degrees below 2^23; a lighter
// weight is rounded to 2^-40.
constexpr double kWeightScale = 1099511627776.0;  // 2^40

std::int64_t fixedPointWeight(float w) { return static_cast<std::int64_t>(double(w) * kWeightScale + 0.5); }

// The bit rows, and the mean weight of each node's edges (0 for isolated nodes): the same whatever the
// thread count. Each row is zeroed and given its own row's bits by the thread that owns it, so that its
// pages are first touched there; that thread adds the row's weights to both of its ends.
struct NeighbourSets {
  NeighbourBits bits;
  std::vector<double> mean;
};

NeighbourSets neighbourSets(const UpperRows& rows, int num_threads) {
  const int n = rows.numNodes();
  NeighbourSets out;
  NeighbourBits& bits = out.bits;
  bits.position.assign(n, -1);
  int active = 0;
  for (int i = 0; i < n; ++i) {
    if (rows.degree[i] > 0) bits.position[i] = active++;
  }
  bits.words = wordsPerRow(std::size_t(active));
  bits.allocate(std::size_t(active));
  std::vector<std::int64_t> sum(n, 0);
#pragma omp parallel num_threads(num_threads)
  {
    std::vector<std::int64_t> local(n, 0);  // integers: summed below in any order
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < n; ++i) {
      if (bits.position[i] < 0) continue;
      std::uint64_t* row = bits.row(i);
      std::fill(row, row + bits.words, std::uint64_t(0));
      std::int64_t own = 0;
      for (int c = 0; c < rows.count[i]; ++c) {
        const int j = rows.to[i][c];
        const std::int64_t w = fixedPointWeight(rows.weight[i][c]);
        bits.set(i, j);
        own += w;
        local[j] += w;
      }
      local[i] += own;
    }
#pragma omp critical
    for (int i = 0; i < n; ++i) sum[i] += local[i];
  }
  mirrorUpperBits(bits, active, num_threads);
  out.mean.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    if (rows.degree[i] > 0) out.mean[i] = double(sum[i]) / kWeightScale / double(rows.degree[i]);
  }
  return out;
}

}  // namespace

bool neighbourCountsFit(const UpperRows& first_order) {
  const std::size_t active = activeNodes(first_order);
  return double(active) * double(wordsPerRow(active)) * 8.0 <= double(kMaxNeighbourBitsBytes);
}

double countedSecondOrderWork(const UpperRows& first_order) {
  return double(first_order.numEdges()) * double(wordsPerRow(activeNodes(first_order)));
}

EdgeSums countedCommonSums(const UpperRows& fog, int num_threads, const StopFlag* stop) {
  // The bit rows of all the nodes exceed L2 (640 bytes each at N = 5000, 3 MB in all), and a chance
  // graph's rows reach almost every node: rows are taken in chunks of kRowsPerChunk, and each chunk's
  // edges column block by column block, so that the chunk and one block stay cached (160 + 128 KB at
  // N = 5000) and each column row is fetched once per chunk, not once per edge.
  constexpr int kRowsPerChunk = 256;
  constexpr std::size_t kColumnBlockBytes = std::size_t(128) << 10;
  const int n = fog.numNodes();
  const NeighbourSets sets = neighbourSets(fog, num_threads);
  const NeighbourBits& bits = sets.bits;
  const std::vector<double>& mean = sets.mean;
  static const kernels::CommonCount count = kernels::activeKernels().common_count.run;
  static const kernels::CommonCounts4 counts4 = kernels::activeKernels().common_counts4.run;
  const int columns = static_cast<int>(
      std::max<std::size_t>(64, kColumnBlockBytes / (8 * std::max<std::size_t>(bits.words, 1))));
  const std::vector<std::int64_t> start = fog.rowStarts();
  EdgeSums common(start.back());  // every entry written below, on the threads
  const int chunks = (n + kRowsPerChunk - 1) / kRowsPerChunk;
#pragma omp parallel num_threads(num_threads)
  {
    int cursor[kRowsPerChunk];
#pragma omp for schedule(dynamic, 1)
    for (int chunk = 0; chunk < chunks; ++chunk) {
      const int first = chunk * kRowsPerChunk, last = std::min(n, first + kRowsPerChunk);
      if (stopRequested(stop)) {  // incomplete, but never unwritten
        std::fill(common.begin() + start[first], common.begin() + start[last], 0.0f);
        continue;
      }
      std::fill(cursor, cursor + (last - first), 0);
      for (int block_end = (first / columns + 1) * columns;; block_end += columns) {
        bool more = false;
        for (int i = first; i < last; ++i) {
          int& c = cursor[i - first];
          const int* const to = fog.to[i];
          float* const sum = common.data() + start[i];
          // Four edges at a time while four are left in the block, then one by one.
          for (; c + 4 <= fog.count[i] && to[c + 3] < block_end; c += 4) {
            const std::uint64_t* const columns_of[4] = {bits.row(to[c]), bits.row(to[c + 1]),
                                                        bits.row(to[c + 2]), bits.row(to[c + 3])};
            std::int64_t shared[4];
            counts4(bits.row(i), columns_of, bits.words, shared);
            for (int k = 0; k < 4; ++k)
              sum[c + k] = static_cast<float>(double(shared[k]) * mean[i] * mean[to[c + k]]);
          }
          for (; c < fog.count[i] && to[c] < block_end; ++c) {
            const std::int64_t shared = count(bits.row(i), bits.row(to[c]), bits.words);
            sum[c] = static_cast<float>(double(shared) * mean[i] * mean[to[c]]);
          }
          more = more || c < fog.count[i];
        }
        if (!more) break;
      }
    }
  }
  return common;
}

}  // namespace mac_registration
