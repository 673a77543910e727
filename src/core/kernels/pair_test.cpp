#include "pair_test.hpp"

#include <cmath>
#include <cstdint>

#if MAC_REGISTRATION_X86
#include <immintrin.h>
#endif

namespace mac_registration {
namespace kernels {
namespace {

// The O(N^2) loop of the graph: branch-free so that it vectorizes, with an AVX2 clone picked at run time
// where the CPU has it (the same IEEE operations, no FMA, so the same edges either way).
MAC_REGISTRATION_CLONES_AVX2 void pairResidualsSquared(const float* sx, const float* sy, const float* sz,
                                                       const float* tx, const float* ty, const float* tz,
                                                       int i, int begin, int end, float* out) {
  const float six = sx[i], siy = sy[i], siz = sz[i], tix = tx[i], tiy = ty[i], tiz = tz[i];
  for (int j = begin; j < end; ++j) {
    const float ds = std::sqrt((six - sx[j]) * (six - sx[j]) + (siy - sy[j]) * (siy - sy[j]) +
                               (siz - sz[j]) * (siz - sz[j]));
    const float dt = std::sqrt((tix - tx[j]) * (tix - tx[j]) + (tiy - ty[j]) * (tiy - ty[j]) +
                               (tiz - tz[j]) * (tiz - tz[j]));
    out[j - begin] = (ds - dt) * (ds - dt);
  }
}

}  // namespace

// Branch-free compaction: almost every pair fails the test, so a branch per pair mispredicts.
int pairTestPortable(const float* sx, const float* sy, const float* sz, const float* tx, const float* ty,
                     const float* tz, int i, int n, float max_d2, float* d2, int* candidates,
                     float* candidate_d2) {
  pairResidualsSquared(sx, sy, sz, tx, ty, tz, i, i + 1, n, d2);
  int found = 0;
  for (int j = i + 1; j < n; ++j) {
    candidates[found] = j;
    candidate_d2[found] = d2[j - i - 1];
    found += d2[j - i - 1] <= max_d2;
  }
  return found;
}

#if MAC_REGISTRATION_X86
namespace {

// For each 8-bit mask, the lanes it sets, ascending, then zeros: the permutation that packs them left.
struct LeftPackLanes {
  alignas(32) std::int32_t lanes[256][8];
  LeftPackLanes() {
    for (int mask = 0; mask < 256; ++mask) {
      int packed = 0;
      for (int lane = 0; lane < 8; ++lane) {
        if (mask & (1 << lane)) lanes[mask][packed++] = lane;
      }
      while (packed < 8) lanes[mask][packed++] = 0;
    }
  }
};

// |p_i - p_j| for the eight points from j (those outside `valid` read as 0), as pairResidualsSquared.
__attribute__((target("avx2"), optimize("fp-contract=off"))) inline __m256 distances8(
    const float* x, const float* y, const float* z, int j, __m256i valid, __m256 xi, __m256 yi, __m256 zi) {
  const __m256 dx = _mm256_sub_ps(xi, _mm256_maskload_ps(x + j, valid));
  const __m256 dy = _mm256_sub_ps(yi, _mm256_maskload_ps(y + j, valid));
  const __m256 dz = _mm256_sub_ps(zi, _mm256_maskload_ps(z + j, valid));
  return _mm256_sqrt_ps(
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
}

}  // namespace

// Eight pairs at a time, the passing ones packed in registers by a table of permutations (AVX2 has no
// compress) and stored whole (8 entries, past the found ones too). The same IEEE operations as
// pairResidualsSquared.
__attribute__((target("avx2,popcnt"), optimize("fp-contract=off"))) int pairTestAvx2(
    const float* sx, const float* sy, const float* sz, const float* tx, const float* ty, const float* tz,
    int i, int n, float max_d2, float*, int* candidates, float* candidate_d2) {
  static const LeftPackLanes pack;
  const __m256 six = _mm256_set1_ps(sx[i]), siy = _mm256_set1_ps(sy[i]), siz = _mm256_set1_ps(sz[i]);
  const __m256 tix = _mm256_set1_ps(tx[i]), tiy = _mm256_set1_ps(ty[i]), tiz = _mm256_set1_ps(tz[i]);
  const __m256 bound = _mm256_set1_ps(max_d2);
  const __m256i first_valid = _mm256_set1_epi32(i), end = _mm256_set1_epi32(n);
  const __m256i step = _mm256_set1_epi32(8);
  // The loads start on the 8-float boundary at or below i + 1 (the arrays are 64-byte aligned), with the
  // pairs below i + 1 masked off: a load across two cache lines would cost two.
  const int start = (i + 1) & ~7;
  __m256i index = _mm256_add_epi32(_mm256_set1_epi32(start), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  int found = 0;
  for (int j = start; j < n; j += 8) {
    // i < index < n, as all-ones lanes
    const __m256i valid =
        _mm256_and_si256(_mm256_cmpgt_epi32(index, first_valid), _mm256_cmpgt_epi32(end, index));
    const __m256 difference = _mm256_sub_ps(distances8(sx, sy, sz, j, valid, six, siy, siz),
                                            distances8(tx, ty, tz, j, valid, tix, tiy, tiz));
    const __m256 d2 = _mm256_mul_ps(difference, difference);
    const __m256 pass = _mm256_and_ps(_mm256_cmp_ps(d2, bound, _CMP_LE_OQ), _mm256_castsi256_ps(valid));
    const int mask = _mm256_movemask_ps(pass);
    const __m256i lanes = _mm256_load_si256(reinterpret_cast<const __m256i*>(pack.lanes[mask]));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(candidates + found),
                        _mm256_permutevar8x32_epi32(index, lanes));
    _mm256_storeu_ps(candidate_d2 + found, _mm256_permutevar8x32_ps(d2, lanes));
    found += __builtin_popcount(static_cast<unsigned>(mask));
    index = _mm256_add_epi32(index, step);
  }
  return found;
}

namespace {

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

}  // namespace

// Sixteen pairs at a time, the test's mask compressing the passing ones straight into place. The same IEEE
// operations in the same order as pairResidualsSquared, so the same pairs and d^2 bit for bit: AVX-512 has
// FMA, and contracting a multiply and an add into one would round differently.
__attribute__((target("avx512f,popcnt"), optimize("fp-contract=off"))) int pairTestAvx512(
    const float* sx, const float* sy, const float* sz, const float* tx, const float* ty, const float* tz,
    int i, int n, float max_d2, float*, int* candidates, float* candidate_d2) {
  const __m512 six = _mm512_set1_ps(sx[i]), siy = _mm512_set1_ps(sy[i]), siz = _mm512_set1_ps(sz[i]);
  const __m512 tix = _mm512_set1_ps(tx[i]), tiy = _mm512_set1_ps(ty[i]), tiz = _mm512_set1_ps(tz[i]);
  const __m512 bound = _mm512_set1_ps(max_d2);
  const __m512i step = _mm512_set1_epi32(16);
  // The loads start on the 16-float boundary at or below i + 1 (the arrays are 64-byte aligned), with the
  // pairs below i + 1 masked off: a load across two cache lines would cost two.
  const int start = (i + 1) & ~15;
  __m512i index = _mm512_add_epi32(_mm512_set1_epi32(start),
                                   _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
  int found = 0;
  for (int j = start; j < n; j += 16) {
    __mmask16 valid = n - j >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (n - j)) - 1u);
    if (j <= i) valid &= __mmask16(~((1u << (i + 1 - j)) - 1u));
    const __m512 difference = _mm512_sub_ps(distances16(sx, sy, sz, j, valid, six, siy, siz),
                                            distances16(tx, ty, tz, j, valid, tix, tiy, tiz));
    const __m512 d2 = _mm512_mul_ps(difference, difference);
    const __mmask16 pass = _mm512_mask_cmp_ps_mask(valid, d2, bound, _CMP_LE_OQ);
    // Compressed in registers and stored whole (16 entries, past the found ones too): a compressing store
    // to memory costs several times more.
    _mm512_storeu_si512(candidates + found, _mm512_maskz_compress_epi32(pass, index));
    _mm512_storeu_ps(candidate_d2 + found, _mm512_maskz_compress_ps(pass, d2));
    found += __builtin_popcount(pass);
    index = _mm512_add_epi32(index, step);
  }
  return found;
}

#endif  // MAC_REGISTRATION_X86

}  // namespace kernels
}  // namespace mac_registration
