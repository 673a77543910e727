#include "common_neighbours.hpp"

#include <algorithm>

#if MAC_REGISTRATION_X86
#include <immintrin.h>
#endif

namespace mac_registration {
namespace kernels {

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

void commonCounts4Portable(const std::uint64_t* a, const std::uint64_t* const b[4], std::size_t words,
                           std::int64_t out[4]) {
  for (int k = 0; k < 4; ++k) out[k] = commonCountPortable(a, b[k], words);
}

#if MAC_REGISTRATION_X86
namespace {

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

}  // namespace

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

}  // namespace kernels
}  // namespace mac_registration
