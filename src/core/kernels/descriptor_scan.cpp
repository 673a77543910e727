#include "descriptor_scan.hpp"

#if MAC_REGISTRATION_X86
#include <immintrin.h>
#endif

namespace mac_registration {
namespace kernels {
namespace {

void offerLanes(const float* d2, const int* targets, int count, BestTwo& best) {
  for (int lane = 0; lane < count; ++lane) best.offer(d2[lane], targets[lane]);
}

// The exact distances d2 of query k to a tile's 16 lanes, offered to those lanes' columns (cd, cq; the
// mutual check's nearest query of each target).
void offerToColumns(const float* d2, const ScanState& s, int k, float* cd, int* cq) {
  for (int lane = 0; lane < kLanes; ++lane) {
    if (d2[lane] < cd[lane]) {
      cd[lane] = d2[lane];
      cq[lane] = s.query_index[k];
    }
  }
}

}  // namespace

// The direct sum for every pair (with the compiler's AVX2 clone where the CPU has it): the sums the SIMD
// variants' rechecks keep.
MAC_REGISTRATION_CLONES_AVX2 __attribute__((optimize("fp-contract=off"))) void scanTilesPortable(
    const ScanState& s, const float* packed, int tile_begin, int tile_end, int distinct_queries) {
  for (int tile = tile_begin; tile < tile_end; ++tile) {
    const float* t = packed + std::size_t(tile) * kBins * kLanes;
    alignas(64) float acc[kQueryGroup][kLanes] = {};
    for (int b = 0; b < kBins; ++b) {
      for (int k = 0; k < kQueryGroup; ++k) {
        const float q = s.query[k][b];
#pragma omp simd aligned(t : 64)
        for (int lane = 0; lane < kLanes; ++lane) {
          const float diff = q - t[b * kLanes + lane];
          acc[k][lane] = acc[k][lane] + diff * diff;
        }
      }
    }
    for (int k = 0; k < distinct_queries; ++k)
      offerLanes(acc[k], s.target_of_slot + tile * kLanes, kLanes, *s.best[k]);
    if (s.column_d2) {
      float* cd = s.column_d2 + std::size_t(tile) * kLanes;
      int* cq = s.column_query + std::size_t(tile) * kLanes;
      for (int k = 0; k < distinct_queries; ++k) offerToColumns(acc[k], s, k, cd, cq);
    }
  }
}

#if MAC_REGISTRATION_X86
namespace {

// The squared distance as the kd-tree sums it: bin by bin, separate multiply and add (not inlined: the
// caller may contract).
__attribute__((noinline, optimize("fp-contract=off"))) float exactSquaredDistance(const float* query,
                                                                                  const float* tile,
                                                                                  int lane) {
  float sum = 0.0f;
  for (int b = 0; b < kBins; ++b) {
    const float diff = query[b] - tile[b * kLanes + lane];
    sum = sum + diff * diff;
  }
  return sum;
}

// Bound on |(|q|^2 + |t|^2 - 2 q.t) - (exact sum)| relative to |q|^2 + |t|^2, both in float with 33 terms:
// each is within 33 units in the last place (6e-8) of (|q|^2 + |t|^2) of the true value (Cauchy-Schwarz
// bounds sum |q_i t_i| by half of it), so 1e-5 holds; 1e-4 leaves a tenfold margin. A candidate whose
// fast distance is not below the best + this bound cannot have an exact distance below the best.
constexpr float kFastFormSlack = 1e-4f;

// Candidates of one query in one tile beyond which the whole tile is recomputed in one go.
constexpr int kScalarRechecks = 2;

// The screen's candidates `maybe` (a mask of lanes) of query k in a tile, rechecked one by one by the
// direct sum: for the query's best two, and for the columns' nearest query (cd, cq: the tile's lanes).
void recheckForBest(const ScanState& s, int k, const float* t, int tile, unsigned maybe) {
  while (maybe) {
    const int lane = __builtin_ctz(maybe);
    maybe &= maybe - 1;
    s.best[k]->offer(exactSquaredDistance(s.query[k], t, lane), s.target_of_slot[tile * kLanes + lane]);
  }
}

void recheckForColumns(const ScanState& s, int k, const float* t, float* cd, int* cq, unsigned maybe) {
  while (maybe) {
    const int lane = __builtin_ctz(maybe);
    maybe &= maybe - 1;
    const float d2 = exactSquaredDistance(s.query[k], t, lane);
    if (d2 < cd[lane]) {
      cd[lane] = d2;
      cq[lane] = s.query_index[k];
    }
  }
}

// exactSquaredDistance for the 16 lanes of a tile at once: the same operations lane by lane.
__attribute__((target("avx512f"), optimize("fp-contract=off"), noinline)) __m512 exactSquaredDistances16(
    const float* query, const float* tile) {
  __m512 sum = _mm512_setzero_ps();
  for (int b = 0; b < kBins; ++b) {
    const __m512 diff = _mm512_sub_ps(_mm512_set1_ps(query[b]), _mm512_load_ps(tile + b * kLanes));
    sum = _mm512_add_ps(sum, _mm512_mul_ps(diff, diff));
  }
  return sum;
}

// exactSquaredDistance for the 16 lanes of a tile at once, as two halves of 8: the same operations lane by
// lane.
__attribute__((target("avx2"), optimize("fp-contract=off"), noinline)) void exactSquaredDistances16Avx2(
    const float* query, const float* tile, float out[kLanes]) {
  __m256 low = _mm256_setzero_ps(), high = _mm256_setzero_ps();
  for (int b = 0; b < kBins; ++b) {
    const __m256 q = _mm256_set1_ps(query[b]);
    const __m256 diff_low = _mm256_sub_ps(q, _mm256_load_ps(tile + b * kLanes));
    const __m256 diff_high = _mm256_sub_ps(q, _mm256_load_ps(tile + b * kLanes + 8));
    low = _mm256_add_ps(low, _mm256_mul_ps(diff_low, diff_low));
    high = _mm256_add_ps(high, _mm256_mul_ps(diff_high, diff_high));
  }
  _mm256_storeu_ps(out, low);
  _mm256_storeu_ps(out + 8, high);
}

// The 16-bit mask of a < b over two halves of 8 lanes.
__attribute__((target("avx2"))) inline int lessMask16(__m256 a_low, __m256 a_high, __m256 b_low,
                                                      __m256 b_high) {
  return _mm256_movemask_ps(_mm256_cmp_ps(a_low, b_low, _CMP_LT_OQ)) |
         (_mm256_movemask_ps(_mm256_cmp_ps(a_high, b_high, _CMP_LT_OQ)) << 8);
}

}  // namespace

// The distances are screened in the dot-product form (one fused multiply-add a bin: a third of the direct
// sum's operations), and every candidate that could be closer than the best so far, within the form's
// rounding bound, is recomputed by the direct sum, the only distance ever kept: the results are the direct
// sum's. A tile's 16 lanes as two halves of 8 (the AVX-512 variant below has them in one register); the dot
// products of one half for the 8 queries at a time (16 accumulators would not fit the 16 registers).
__attribute__((target("avx2,fma"))) void scanTilesAvx2(const ScanState& s, const float* packed,
                                                       int tile_begin, int tile_end, int distinct_queries) {
  for (int tile = tile_begin; tile < tile_end; ++tile) {
    const float* t = packed + std::size_t(tile) * kBins * kLanes;
    alignas(32) float fast[kQueryGroup][kLanes], slack[kQueryGroup][kLanes];
    for (int half = 0; half < kLanes; half += 8) {
      __m256 dot[kQueryGroup];
      for (int k = 0; k < kQueryGroup; ++k) dot[k] = _mm256_setzero_ps();
      for (int b = 0; b < kBins; ++b) {
        const __m256 row = _mm256_load_ps(t + b * kLanes + half);
        for (int k = 0; k < kQueryGroup; ++k)
          dot[k] = _mm256_fmadd_ps(_mm256_set1_ps(s.query[k][b]), row, dot[k]);
      }
      const __m256 target_norms = _mm256_load_ps(s.target_norms + std::size_t(tile) * kLanes + half);
      for (int k = 0; k < kQueryGroup; ++k) {
        const __m256 norms = _mm256_add_ps(_mm256_set1_ps(s.query_norm[k]), target_norms);
        _mm256_store_ps(fast[k] + half, _mm256_fmadd_ps(_mm256_set1_ps(-2.0f), dot[k], norms));
        _mm256_store_ps(slack[k] + half, _mm256_mul_ps(_mm256_set1_ps(kFastFormSlack), norms));
      }
    }
    for (int k = 0; k < distinct_queries; ++k) {
      const __m256 second = _mm256_set1_ps(s.best[k]->second);
      int maybe = lessMask16(_mm256_load_ps(fast[k]), _mm256_load_ps(fast[k] + 8),
                             _mm256_add_ps(second, _mm256_load_ps(slack[k])),
                             _mm256_add_ps(second, _mm256_load_ps(slack[k] + 8)));
      if (__builtin_popcount(maybe) > kScalarRechecks) {
        alignas(32) float d2[kLanes];
        exactSquaredDistances16Avx2(s.query[k], t, d2);
        offerLanes(d2, s.target_of_slot + tile * kLanes, kLanes, *s.best[k]);
        continue;
      }
      recheckForBest(s, k, t, tile, maybe);
    }
    if (s.column_d2) {
      float* cd = s.column_d2 + std::size_t(tile) * kLanes;
      int* cq = s.column_query + std::size_t(tile) * kLanes;
      for (int k = 0; k < distinct_queries; ++k) {  // ascending query index: strict < keeps the lowest
        const __m256 column_low = _mm256_loadu_ps(cd), column_high = _mm256_loadu_ps(cd + 8);
        int maybe = lessMask16(_mm256_load_ps(fast[k]), _mm256_load_ps(fast[k] + 8),
                               _mm256_add_ps(column_low, _mm256_load_ps(slack[k])),
                               _mm256_add_ps(column_high, _mm256_load_ps(slack[k] + 8)));
        if (maybe == 0) continue;
        if (__builtin_popcount(maybe) > kScalarRechecks) {
          alignas(32) float d2[kLanes];
          exactSquaredDistances16Avx2(s.query[k], t, d2);
          offerToColumns(d2, s, k, cd, cq);
          continue;
        }
        recheckForColumns(s, k, t, cd, cq, maybe);
      }
    }
  }
}

// The AVX2 variant's screen and rechecks with a tile's 16 lanes in one register.
__attribute__((target("avx512f"))) void scanTilesAvx512(const ScanState& s, const float* packed,
                                                        int tile_begin, int tile_end, int distinct_queries) {
  for (int tile = tile_begin; tile < tile_end; ++tile) {
    const float* t = packed + std::size_t(tile) * kBins * kLanes;
    __m512 dot[kQueryGroup];
    for (int k = 0; k < kQueryGroup; ++k) dot[k] = _mm512_setzero_ps();
    for (int b = 0; b < kBins; ++b) {
      const __m512 row = _mm512_load_ps(t + b * kLanes);
      for (int k = 0; k < kQueryGroup; ++k)
        dot[k] = _mm512_fmadd_ps(_mm512_set1_ps(s.query[k][b]), row, dot[k]);
    }
    const __m512 target_norms = _mm512_load_ps(s.target_norms + std::size_t(tile) * kLanes);
    __m512 fast[kQueryGroup], slack[kQueryGroup];
    for (int k = 0; k < kQueryGroup; ++k) {
      const __m512 norms = _mm512_add_ps(_mm512_set1_ps(s.query_norm[k]), target_norms);
      fast[k] = _mm512_fmadd_ps(_mm512_set1_ps(-2.0f), dot[k], norms);
      slack[k] = _mm512_mul_ps(_mm512_set1_ps(kFastFormSlack), norms);  // +inf / NaN in padding lanes
    }
    for (int k = 0; k < distinct_queries; ++k) {
      const __m512 limit = _mm512_add_ps(_mm512_set1_ps(s.best[k]->second), slack[k]);
      __mmask16 maybe = _mm512_cmp_ps_mask(fast[k], limit, _CMP_LT_OQ);
      if (__builtin_popcount(maybe) > kScalarRechecks) {  // the first tiles: all 16 at once
        alignas(64) float d2[kLanes];
        _mm512_store_ps(d2, exactSquaredDistances16(s.query[k], t));
        offerLanes(d2, s.target_of_slot + tile * kLanes, kLanes, *s.best[k]);  // padding: +inf, never taken
        continue;
      }
      recheckForBest(s, k, t, tile, maybe);
    }
    if (s.column_d2) {
      float* cd = s.column_d2 + std::size_t(tile) * kLanes;
      int* cq = s.column_query + std::size_t(tile) * kLanes;
      __m512 column = _mm512_loadu_ps(cd);          // reloaded only after a lane changed
      for (int k = 0; k < distinct_queries; ++k) {  // ascending query index: strict < keeps the lowest
        __mmask16 maybe = _mm512_cmp_ps_mask(fast[k], _mm512_add_ps(column, slack[k]), _CMP_LT_OQ);
        if (maybe == 0) continue;
        if (__builtin_popcount(maybe) > kScalarRechecks) {
          const __m512 d2 = exactSquaredDistances16(s.query[k], t);
          const __mmask16 closer = _mm512_cmp_ps_mask(d2, column, _CMP_LT_OQ);
          column = _mm512_mask_mov_ps(column, closer, d2);
          _mm512_storeu_ps(cd, column);
          _mm512_storeu_si512(
              cq, _mm512_mask_mov_epi32(_mm512_loadu_si512(cq), closer, _mm512_set1_epi32(s.query_index[k])));
          continue;
        }
        recheckForColumns(s, k, t, cd, cq, maybe);
        column = _mm512_loadu_ps(cd);
      }
    }
  }
}

#endif  // MAC_REGISTRATION_X86

}  // namespace kernels
}  // namespace mac_registration
