// Second-order weights of dense chance graphs estimated from common-neighbour counts (the exact sums are in
// compatibility_graph.cpp): bit rows of the neighbour sets, ANDed and counted a chunk of rows at a time.
#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <vector>

#include "compatibility_graph.hpp"
#include "cpu_kernels.hpp"

#if MAC_REGISTRATION_X86
#include <immintrin.h>
#endif

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

// Transposes a 64 x 64 bit block in place, bit c of a[r] being entry (r, c): swaps its off-diagonal
// halves, then the quarters' within each half, down to single bits.
void transposeBitsPortable(std::uint64_t a[64]) {
  std::uint64_t mask = 0x00000000FFFFFFFFull;
  for (int j = 32; j != 0; j >>= 1, mask ^= mask << j) {
    for (int k = 0; k < 64; k = ((k | j) + 1) & ~j) {
      const std::uint64_t t = ((a[k] >> j) ^ a[k | j]) & mask;
      a[k | j] ^= t;
      a[k] ^= t << j;
    }
  }
}

#if MAC_REGISTRATION_X86
// GCC 12 warns of the undefined vectors its AVX-512 shift and blend intrinsics start from (a false
// positive, GCC bug 105593).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// A stage of that swap between rows k (in x) and k + J, in a register J / 8 further on.
template <int J>
__attribute__((target("avx512f"), always_inline)) inline void swapAcross(__m512i& x, __m512i& y,
                                                                         std::uint64_t mask) {
  const __m512i t = _mm512_and_si512(_mm512_xor_si512(_mm512_srli_epi64(x, J), y), _mm512_set1_epi64(mask));
  y = _mm512_xor_si512(y, t);
  x = _mm512_xor_si512(x, _mm512_slli_epi64(t, J));
}

// A stage between the lanes k and k ^ J of one register (`partner` permutes them; `upper` marks the k + J).
template <int J>
__attribute__((target("avx512f"), always_inline)) inline void swapWithin(__m512i& x, __m512i partner,
                                                                         __mmask8 upper, std::uint64_t mask) {
  const __m512i t =
      _mm512_and_si512(_mm512_xor_si512(_mm512_srli_epi64(x, J), _mm512_permutexvar_epi64(partner, x)),
                       _mm512_set1_epi64(mask));
  x = _mm512_xor_si512(
      x, _mm512_mask_blend_epi64(upper, _mm512_slli_epi64(t, J), _mm512_permutexvar_epi64(partner, t)));
}

// The same swaps on eight rows a register, all six stages in registers: a tenth of the portable time.
__attribute__((target("avx512f"))) void transposeBitsAvx512(std::uint64_t a[64]) {
  __m512i r[8];
  for (int m = 0; m < 8; ++m) r[m] = _mm512_loadu_si512(a + 8 * m);
  for (int m = 0; m < 4; ++m) swapAcross<32>(r[m], r[m + 4], 0x00000000FFFFFFFFull);
  for (const int m : {0, 1, 4, 5}) swapAcross<16>(r[m], r[m + 2], 0x0000FFFF0000FFFFull);
  for (const int m : {0, 2, 4, 6}) swapAcross<8>(r[m], r[m + 1], 0x00FF00FF00FF00FFull);
  const __m512i partner4 = _mm512_setr_epi64(4, 5, 6, 7, 0, 1, 2, 3);
  const __m512i partner2 = _mm512_setr_epi64(2, 3, 0, 1, 6, 7, 4, 5);
  const __m512i partner1 = _mm512_setr_epi64(1, 0, 3, 2, 5, 4, 7, 6);
  for (int m = 0; m < 8; ++m) {
    swapWithin<4>(r[m], partner4, 0xF0, 0x0F0F0F0F0F0F0F0Full);
    swapWithin<2>(r[m], partner2, 0xCC, 0x3333333333333333ull);
    swapWithin<1>(r[m], partner1, 0xAA, 0x5555555555555555ull);
  }
  for (int m = 0; m < 8; ++m) _mm512_storeu_si512(a + 8 * m, r[m]);
}

#pragma GCC diagnostic pop

#endif  // MAC_REGISTRATION_X86

using TransposeBits = void (*)(std::uint64_t*);

TransposeBits transposeBitsForThisCpu() {
#if MAC_REGISTRATION_X86
  if (avx512Kernels()) return transposeBitsAvx512;
#endif
  return transposeBitsPortable;
}

// Gives every bit row its lower bits, the transpose of the upper ones that its own rows set: block
// (r, c) of 64 x 64 bits, above the diagonal, is ORed transposed into block (c, r). Each thread writes the
// lower blocks of its own block rows and reads only upper blocks, which no thread writes here.
void mirrorUpperBits(NeighbourBits& bits, int active, int num_threads) {
  static const TransposeBits transposeBits = transposeBitsForThisCpu();
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

#if MAC_REGISTRATION_X86
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

#endif  // MAC_REGISTRATION_X86

// Four running counts (rows are whole 512-bit blocks, so words is a multiple of 8): one count would wait
// on each word's popcount in turn.
MAC_REGISTRATION_CLONES_POPCNT std::int64_t commonCountPortable(const std::uint64_t* a,
                                                                const std::uint64_t* b, std::size_t words) {
  std::int64_t count[4] = {0, 0, 0, 0};
  for (std::size_t w = 0; w < words; w += 4) {
    for (std::size_t k = 0; k < 4; ++k) count[k] += __builtin_popcountll(a[w + k] & b[w + k]);
  }
  return count[0] + count[1] + count[2] + count[3];
}

#if MAC_REGISTRATION_X86
// The counts of row a against four rows at once: a's words are loaded once for the four, and the four
// sums are independent chains.
__attribute__((target("avx512f,avx512vpopcntdq"))) void commonCounts4Avx512(const std::uint64_t* a,
                                                                            const std::uint64_t* const b[4],
                                                                            std::size_t words,
                                                                            std::int64_t out[4]) {
  __m512i count[4] = {_mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512(),
                      _mm512_setzero_si512()};
  for (std::size_t w = 0; w < words; w += 8) {
    const __m512i row = _mm512_loadu_si512(a + w);
    for (int k = 0; k < 4; ++k)
      count[k] = _mm512_add_epi64(count[k],
                                  _mm512_popcnt_epi64(_mm512_and_si512(row, _mm512_loadu_si512(b[k] + w))));
  }
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"  // as in commonCountAvx512
  for (int k = 0; k < 4; ++k) out[k] = _mm512_reduce_add_epi64(count[k]);
#pragma GCC diagnostic pop
}

#endif  // MAC_REGISTRATION_X86

void commonCounts4Portable(const std::uint64_t* a, const std::uint64_t* const b[4], std::size_t words,
                           std::int64_t out[4]) {
  for (int k = 0; k < 4; ++k) out[k] = commonCountPortable(a, b[k], words);
}

#if MAC_REGISTRATION_X86
// Per-byte popcounts of 256 bits, from a table of the sixteen nibbles' counts (AVX2 has no vector popcount).
__attribute__((target("avx2"))) inline __m256i bytePopcounts(__m256i v) {
  const __m256i nibble_counts = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2,
                                                 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4);
  const __m256i low = _mm256_set1_epi8(0x0F);
  return _mm256_add_epi8(_mm256_shuffle_epi8(nibble_counts, _mm256_and_si256(v, low)),
                         _mm256_shuffle_epi8(nibble_counts, _mm256_and_si256(_mm256_srli_epi16(v, 4), low)));
}

__attribute__((target("avx2"))) inline std::int64_t sumOfLanes(__m256i v) {
  const __m128i half = _mm_add_epi64(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  return _mm_cvtsi128_si64(half) + _mm_extract_epi64(half, 1);
}

// The counts of row a against Columns rows, as commonCounts4Avx512 (words a multiple of 4). The byte counts
// are summed as bytes for up to 31 blocks of 256 bits (at most 8 a block, so below 256), then widened into
// 64-bit lanes.
template <int Columns>
__attribute__((target("avx2"))) void commonCountsAvx2(const std::uint64_t* a, const std::uint64_t* const b[],
                                                      std::size_t words, std::int64_t out[]) {
  constexpr std::size_t kBlocksPerByteSum = 31;
  const __m256i zero = _mm256_setzero_si256();
  __m256i count[Columns];
  for (int k = 0; k < Columns; ++k) count[k] = zero;
  for (std::size_t w = 0; w < words;) {
    const std::size_t stop = std::min(words, w + 4 * kBlocksPerByteSum);
    __m256i bytes[Columns];
    for (int k = 0; k < Columns; ++k) bytes[k] = zero;
    for (; w < stop; w += 4) {
      const __m256i row = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a + w));
      for (int k = 0; k < Columns; ++k) {
        const __m256i column = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b[k] + w));
        bytes[k] = _mm256_add_epi8(bytes[k], bytePopcounts(_mm256_and_si256(row, column)));
      }
    }
    for (int k = 0; k < Columns; ++k) count[k] = _mm256_add_epi64(count[k], _mm256_sad_epu8(bytes[k], zero));
  }
  for (int k = 0; k < Columns; ++k) out[k] = sumOfLanes(count[k]);
}

__attribute__((target("avx2"))) void commonCounts4Avx2(const std::uint64_t* a,
                                                       const std::uint64_t* const b[4], std::size_t words,
                                                       std::int64_t out[4]) {
  commonCountsAvx2<4>(a, b, words, out);
}

__attribute__((target("avx2"))) std::int64_t commonCountAvx2(const std::uint64_t* a, const std::uint64_t* b,
                                                             std::size_t words) {
  const std::uint64_t* const column[1] = {b};
  std::int64_t out[1];
  commonCountsAvx2<1>(a, column, words, out);
  return out[0];
}

#endif  // MAC_REGISTRATION_X86

using CommonCount = std::int64_t (*)(const std::uint64_t*, const std::uint64_t*, std::size_t);
using CommonCounts4 = void (*)(const std::uint64_t*, const std::uint64_t* const*, std::size_t, std::int64_t*);

CommonCount commonCountForThisCpu() {
#if MAC_REGISTRATION_X86
  if (avx512PopcountKernels()) return commonCountAvx512;
  if (avx2Kernels()) return commonCountAvx2;
#endif
  return commonCountPortable;
}

CommonCounts4 commonCounts4ForThisCpu() {
#if MAC_REGISTRATION_X86
  if (avx512PopcountKernels()) return commonCounts4Avx512;
  if (avx2Kernels()) return commonCounts4Avx2;
#endif
  return commonCounts4Portable;
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
  static const CommonCount count = commonCountForThisCpu();
  static const CommonCounts4 counts4 = commonCounts4ForThisCpu();
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
