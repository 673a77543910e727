#include "mac_registration/features/feature_matching.hpp"

#include <omp.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

#include "cpu_kernels.hpp"

#if MAC_REGISTRATION_X86
#include <immintrin.h>
#endif

namespace mac_registration {

// FLANN's single kd-tree, built with PCL's defaults (exact search). Each match searches a copy of it with
// its own epsilon: the copy shares FLANN's index (PCL copies the pointer) and holds only the search
// parameters and PCL's index mapping, so the matches never write to what they share.
struct DescriptorIndex::Tree {
  pcl::KdTreeFLANN<pcl::FPFHSignature33> flann;
};

DescriptorIndex::DescriptorIndex(FpfhCloud::ConstPtr descriptors) : descriptors_(std::move(descriptors)) {}

DescriptorIndex::~DescriptorIndex() = default;

bool DescriptorIndex::built() const { return built_.load(std::memory_order_acquire); }

const DescriptorIndex::Tree& DescriptorIndex::tree() const {
  std::call_once(tree_once_, [this] {
    auto tree = std::make_unique<Tree>();
    tree->flann.setInputCloud(descriptors_);
    tree_ = std::move(tree);
    built_.store(true, std::memory_order_release);
  });
  return *tree_;
}

namespace {

// A norm as a sort key: a descriptor with a NaN bin (never a match) goes last, and the order stays a
// strict weak one.
float sortableNorm(float squared_norm) {
  return std::isnan(squared_norm) ? std::numeric_limits<float>::infinity() : squared_norm;
}

}  // namespace

const DescriptorIndex::Packed& DescriptorIndex::packed() const {
  std::call_once(packed_once_, [this] {
    auto packed = std::make_unique<Packed>();
    const FpfhCloud& d = *descriptors_;
    packed->count = static_cast<int>(d.size());
    packed->tiles = (packed->count + kPackedLanes - 1) / kPackedLanes;
    const std::size_t floats = std::size_t(packed->tiles) * kDimensions * kPackedLanes;
    // Aligned for whole-register loads; +inf in the padding lanes: their distance is +inf, never below
    // the best found (an infinite best is never replaced by an infinite distance either).
    packed->values = {static_cast<float*>(std::aligned_alloc(64, std::max<std::size_t>(floats, 1) * 4)),
                      [](float* f) { std::free(f); }};
    std::fill(packed->values.get(), packed->values.get() + floats, std::numeric_limits<float>::infinity());
    const std::size_t lanes = std::size_t(packed->tiles) * kPackedLanes;
    packed->squared_norms = {
        static_cast<float*>(std::aligned_alloc(64, std::max<std::size_t>(lanes, 16) * 4)),
        [](float* f) { std::free(f); }};
    std::fill(packed->squared_norms.get(), packed->squared_norms.get() + lanes,
              std::numeric_limits<float>::infinity());
    std::vector<float> norm(d.size());
    for (int i = 0; i < packed->count; ++i) {
      float sum = 0.0f;
      for (int b = 0; b < kDimensions; ++b) sum += d[i].histogram[b] * d[i].histogram[b];
      norm[i] = sum;
    }
    std::vector<int> by_norm(d.size());
    for (int i = 0; i < packed->count; ++i) by_norm[i] = i;
    std::stable_sort(by_norm.begin(), by_norm.end(),
                     [&](int a, int b) { return sortableNorm(norm[a]) < sortableNorm(norm[b]); });
    packed->descriptor_of_slot.assign(lanes, -1);
    packed->tile_norm_low.assign(packed->tiles, std::numeric_limits<double>::infinity());
    packed->tile_norm_high.assign(packed->tiles, 0.0);
    for (int slot = 0; slot < packed->count; ++slot) {
      const int i = by_norm[slot], tile = slot / kPackedLanes, lane = slot % kPackedLanes;
      packed->descriptor_of_slot[slot] = i;
      packed->squared_norms[slot] = norm[i];
      const double euclidean = std::sqrt(double(norm[i]));
      packed->tile_norm_low[tile] = std::min(packed->tile_norm_low[tile], euclidean);
      packed->tile_norm_high[tile] = std::max(packed->tile_norm_high[tile], euclidean);
      for (int b = 0; b < kDimensions; ++b)
        packed->values[(std::size_t(tile) * kDimensions + b) * kPackedLanes + lane] = d[i].histogram[b];
    }
    packed_ = std::move(packed);
    built_.store(true, std::memory_order_release);
  });
  return *packed_;
}

namespace {

constexpr int kLanes = DescriptorIndex::kPackedLanes;
constexpr int kBins = DescriptorIndex::kDimensions;
static_assert(sizeof(pcl::FPFHSignature33::histogram) == kBins * sizeof(float), "FPFH has 33 bins");
// Queries scanned together against one tile: each loaded tile row serves this many queries.
constexpr int kQueryGroup = 8;
// Queries an OpenMP chunk holds (their best stays in L1), and targets scanned before the next group of
// queries (kTargetChunkTiles * 33 * 16 floats = 135 KB: stays in L2 across the chunk's queries).
constexpr int kQueryChunk = 64;
constexpr int kTargetChunkTiles = 64;

// The best two of one query so far, squared distances; targets arrive in any order.
struct BestTwo {
  float first = std::numeric_limits<float>::infinity();
  float second = std::numeric_limits<float>::infinity();
  int index = -1;
  // Of two targets at the nearest distance the lower index is kept, the other's distance is the second.
  void offer(float d2, int target) {
    if (d2 < first || (d2 == first && target >= 0 && target < index)) {
      second = first;
      first = d2;
      index = target;
    } else if (d2 < second) {
      second = d2;
    }
  }
};

// What one scan of a group of queries against a range of tiles updates: each query's best two and, with
// the mutual check, each target's nearest query so far (squared distance, query index; ties: the lower).
struct ScanState {
  const float* query[kQueryGroup];  // 33 bins each; repeated when the group is short
  int query_index[kQueryGroup];
  BestTwo* best[kQueryGroup];
  float query_norm[kQueryGroup];  // squared Euclidean norms
  const float* target_norms;      // squared Euclidean norms, indexed by tile * kLanes + lane; +inf padding
  const int* target_of_slot;      // the descriptor at tile * kLanes + lane, -1 in the padding
  float* column_d2;               // null without the mutual check; else indexed by tile * kLanes + lane
  int* column_query;
};

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

// The SIMD scans' pieces: the exact recheck, the fast form's bound, the kernels.
#if MAC_REGISTRATION_X86
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

// AVX-512: 16 targets a register, 8 queries a group. The distances are screened in the dot-product form
// (one fused multiply-add a bin: a third of the direct sum's operations) and every candidate that could be
// closer than the best so far, within the form's rounding bound, is recomputed by the direct sum, the only
// distance ever kept: the results are the direct sum's.
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

// exactSquaredDistances16 with AVX2, a tile's 16 lanes as two halves of 8.
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

// scanTilesAvx512 with AVX2 and FMA: the same screen in the dot-product form and the same rechecks, each
// 16-lane register as two halves of 8; the dot products of one half for the 8 queries at a time (16
// accumulators would not fit the 16 registers).
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

#endif  // MAC_REGISTRATION_X86

// Without AVX2 and FMA (or with the kernels narrowed to the portable ones; then an AVX2 clone where the CPU
// has it): the direct sum for every pair, the same sums as above.
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

using ScanTiles = void (*)(const ScanState&, const float*, int, int, int);

ScanTiles scanTilesForThisCpu() {
#if MAC_REGISTRATION_X86
  if (avx512Kernels()) return scanTilesAvx512;
  if (avx2Kernels()) return scanTilesAvx2;
#endif
  return scanTilesPortable;
}

// The scan state of queries [q, q + kQueryGroup) of `order` (the last one repeated for a short group).
ScanState groupState(const FpfhCloud& queries, const std::vector<float>& query_norms, const int* order, int q,
                     int end, const DescriptorIndex::Packed& packed, std::vector<BestTwo>& best,
                     int& distinct) {
  ScanState s;
  distinct = std::min(kQueryGroup, end - q);
  for (int k = 0; k < kQueryGroup; ++k) {
    const int i = order[q + std::min(k, distinct - 1)];
    s.query[k] = queries[i].histogram;
    s.query_index[k] = i;
    s.best[k] = &best[i];
    s.query_norm[k] = query_norms[i];
  }
  s.target_norms = packed.squared_norms.get();
  s.target_of_slot = packed.descriptor_of_slot.data();
  s.column_d2 = nullptr;
  s.column_query = nullptr;
  return s;
}

// One OpenMP chunk: queries [begin, end) of `order` against every target, tile range by tile range (the
// mutual check needs every pair: each target's nearest query).
void scanQueryChunk(const FpfhCloud& queries, const std::vector<float>& query_norms, const int* order,
                    int begin, int end, const DescriptorIndex::Packed& packed, ScanTiles scan,
                    std::vector<BestTwo>& best, float* column_d2, int* column_query) {
  for (int tile_begin = 0; tile_begin < packed.tiles; tile_begin += kTargetChunkTiles) {
    const int tile_end = std::min(packed.tiles, tile_begin + kTargetChunkTiles);
    for (int q = begin; q < end; q += kQueryGroup) {
      int distinct = 0;
      ScanState s = groupState(queries, query_norms, order, q, end, packed, best, distinct);
      s.column_d2 = column_d2;
      s.column_query = column_query;
      scan(s, packed.values.get(), tile_begin, tile_end, distinct);
    }
  }
}

// Whether no target of `tile` can come within the second nearest distance of any query of the group:
// | |q| - |t| | <= |q - t|, with margins above the rounding of the norms (2e-6 relative) and of the
// direct sum (33 terms: 2e-6 relative), so that a skipped target could neither be nearer than the second
// nor tie it.
bool tileBeyondGroup(const ScanState& s, int distinct, const double* query_norm,
                     const DescriptorIndex::Packed& packed, int tile, bool above) {
  for (int k = 0; k < distinct; ++k) {
    const double second = s.best[k]->second;
    if (!std::isfinite(second)) return false;
    const double gap =
        above ? packed.tile_norm_low[tile] - query_norm[k] : query_norm[k] - packed.tile_norm_high[tile];
    const double margin = 1e-5 * (query_norm[k] + packed.tile_norm_high[tile]) + 1e-6;
    if (gap <= margin || (gap - margin) * (gap - margin) * (1.0 - 1e-5) <= second) return false;
  }
  return true;
}

// Queries [begin, end) of `order` (ascending norm), a group at a time, against the tiles outward from the
// group's norm: the tiles are in norm order, so once a tile is beyond every query of the group in one
// direction, every later tile that way is too. Each query's two nearest are those of the full scan.
void scanQueryChunkByNorm(const FpfhCloud& queries, const std::vector<float>& query_norms, const int* order,
                          int begin, int end, const DescriptorIndex::Packed& packed, ScanTiles scan,
                          std::vector<BestTwo>& best) {
  for (int q = begin; q < end; q += kQueryGroup) {
    int distinct = 0;
    const ScanState s = groupState(queries, query_norms, order, q, end, packed, best, distinct);
    double norm[kQueryGroup];
    for (int k = 0; k < kQueryGroup; ++k) norm[k] = std::sqrt(double(s.query_norm[k]));
    const float middle = s.query_norm[distinct / 2];
    const float* sorted = packed.squared_norms.get();
    const int start_slot = int(std::lower_bound(sorted, sorted + packed.count, middle) - sorted);
    int above = std::min(packed.tiles - 1, start_slot / kLanes), below = above - 1;
    bool up = true, down = below >= 0;
    while (up || down) {
      if (up) {
        up = above < packed.tiles && !tileBeyondGroup(s, distinct, norm, packed, above, true);
        if (up) scan(s, packed.values.get(), above, above + 1, distinct), ++above;
      }
      if (down) {
        down = below >= 0 && !tileBeyondGroup(s, distinct, norm, packed, below, false);
        if (down) scan(s, packed.values.get(), below, below + 1, distinct), --below;
      }
    }
  }
}

float squaredNorm(const float* bins) {
  float sum = 0.0f;
  for (int b = 0; b < kBins; ++b) sum += bins[b] * bins[b];
  return sum;
}

NearestDescriptors fromSquared(const BestTwo& b) {
  NearestDescriptors n;
  n.nearest = b.index;
  if (b.index >= 0) n.nearest_distance = std::sqrt(b.first);
  if (b.index >= 0) n.second_distance = std::sqrt(b.second);
  return n;
}

}  // namespace

std::vector<NearestDescriptors> nearestDescriptorsBruteForce(const FpfhCloud& queries,
                                                             const DescriptorIndex& reference, int threads,
                                                             std::vector<NearestDescriptors>* reverse,
                                                             const StopFlag* stop) {
  const DescriptorIndex::Packed& packed = reference.packed();
  static const ScanTiles scan = scanTilesForThisCpu();
  const int count = static_cast<int>(queries.size());
  std::vector<BestTwo> best(queries.size());
  std::vector<float> query_norms(queries.size());
  for (int q = 0; q < count; ++q) query_norms[q] = squaredNorm(queries[q].histogram);
  // Without the reverse search the queries go by ascending norm, so that a group's queries share the tiles
  // near their norm; with it every pair is scanned, in query order (the columns keep the lowest query).
  std::vector<int> order(queries.size());
  for (int q = 0; q < count; ++q) order[q] = q;
  if (!reverse) {
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return sortableNorm(query_norms[a]) < sortableNorm(query_norms[b]);
    });
  }
  const std::size_t columns = std::size_t(packed.tiles) * kLanes;
  const int chunks = (count + kQueryChunk - 1) / kQueryChunk;
  threads = std::max(1, std::min(threads, chunks));
  // With the reverse search each thread keeps its own column minima, merged afterwards by (distance,
  // query index): the merge's result does not depend on which thread scanned which chunk.
  std::vector<float> column_d2;
  std::vector<int> column_query;
  if (reverse) {
    column_d2.assign(columns * threads, std::numeric_limits<float>::infinity());
    column_query.assign(columns * threads, -1);
  }
#pragma omp parallel num_threads(threads)
  {
    const std::size_t offset = columns * std::size_t(omp_get_thread_num());
    float* cd = reverse ? column_d2.data() + offset : nullptr;
    int* cq = reverse ? column_query.data() + offset : nullptr;
#pragma omp for schedule(dynamic, 1)
    for (int c = 0; c < chunks; ++c) {
      if (stopRequested(stop)) continue;  // a chunk scans every tile: milliseconds on a large target
      const int begin = c * kQueryChunk, end = std::min(count, (c + 1) * kQueryChunk);
      if (reverse) {
        scanQueryChunk(queries, query_norms, order.data(), begin, end, packed, scan, best, cd, cq);
      } else {
        scanQueryChunkByNorm(queries, query_norms, order.data(), begin, end, packed, scan, best);
      }
    }
  }
  throwIfStopped(stop, "matching descriptors");
  std::vector<NearestDescriptors> result(queries.size());
  for (int q = 0; q < count; ++q) result[q] = fromSquared(best[q]);
  if (reverse) {
    reverse->assign(packed.count, NearestDescriptors{});
    for (int slot = 0; slot < packed.count; ++slot) {
      const int t = packed.descriptor_of_slot[slot];
      float d2 = std::numeric_limits<float>::infinity();
      int who = -1;
      for (int th = 0; th < threads; ++th) {
        const float d = column_d2[columns * th + slot];
        const int w = column_query[columns * th + slot];
        if (w >= 0 && (who < 0 || d < d2 || (d == d2 && w < who))) {
          d2 = d;
          who = w;
        }
      }
      (*reverse)[t].nearest = who;
      if (who >= 0) (*reverse)[t].nearest_distance = std::sqrt(d2);
    }
  }
  return result;
}

// With eps = 0 (PCL's default) the search is exact; with eps > 0 it skips every branch that cannot hold a
// descriptor closer than (nearest found) / (1 + eps): in 33 dimensions most of the exact search's time goes
// into confirming what it has already found. Either way the tree and the search are deterministic, so
// results do not depend on threads.
std::vector<NearestDescriptors> nearestDescriptorsKdTree(const FpfhCloud& queries,
                                                         const std::vector<int>* which,
                                                         const DescriptorIndex& reference, int k,
                                                         double epsilon, int threads, const StopFlag* stop) {
  pcl::KdTreeFLANN<pcl::FPFHSignature33> tree = reference.tree().flann;
  tree.setEpsilon(static_cast<float>(epsilon));
  std::vector<NearestDescriptors> result(queries.size());
  const int count = static_cast<int>(which ? which->size() : queries.size());
#pragma omp parallel num_threads(threads)
  {
    pcl::Indices indices(k);
    std::vector<float> squared(k);
    StopCheck check(stop);
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < count; ++i) {
      if (check.stopped()) continue;
      const int q = which ? (*which)[i] : i;
      const int found = tree.nearestKSearch(queries[q], k, indices, squared);
      if (found < 1) continue;
      result[q].nearest = indices[0];
      result[q].nearest_distance = std::sqrt(squared[0]);
      if (found > 1) result[q].second_distance = std::sqrt(squared[1]);
    }
  }
  throwIfStopped(stop, "matching descriptors");
  return result;
}

namespace {

// The targets some source descriptor found nearest, ascending: the only ones the mutual check asks about.
std::vector<int> nearestTargets(const std::vector<NearestDescriptors>& forward, std::size_t targets) {
  std::vector<char> found(targets, 0);
  for (const NearestDescriptors& n : forward) {
    if (n.nearest >= 0) found[n.nearest] = 1;
  }
  std::vector<int> which;
  for (int t = 0; t < static_cast<int>(targets); ++t) {
    if (found[t]) which.push_back(t);
  }
  return which;
}

}  // namespace

std::vector<FeatureMatch> matchFeatures(const DescriptorIndex& source, const DescriptorIndex& target,
                                        const FeatureParams& params, MatchingStats& stats,
                                        const StopFlag* stop) {
  stats = MatchingStats{};
  const FpfhCloud& source_descriptors = *source.descriptors();
  const FpfhCloud& target_descriptors = *target.descriptors();
  if (source_descriptors.empty() || target_descriptors.empty()) return {};
  const int threads = params.num_threads > 0 ? params.num_threads : omp_get_max_threads();
  const bool ratio_test = params.ratio_test > 0.0;
  std::vector<NearestDescriptors> forward, backward;
  // Exact: the brute force, faster than the exact kd-tree on every size measured (1 000 to 19 500
  // descriptors, doc/decisions/exact-descriptor-search.md).
  if (params.match_epsilon == 0.0) {
    forward = nearestDescriptorsBruteForce(source_descriptors, target, threads,
                                           params.mutual_filter ? &backward : nullptr, stop);
  } else {
    forward = nearestDescriptorsKdTree(source_descriptors, nullptr, target, ratio_test ? 2 : 1,
                                       params.match_epsilon, threads, stop);
    if (params.mutual_filter) {
      const std::vector<int> asked = nearestTargets(forward, target_descriptors.size());
      backward = nearestDescriptorsKdTree(target_descriptors, &asked, source, 1, params.match_epsilon,
                                          threads, stop);
    }
  }

  std::vector<FeatureMatch> matches;
  matches.reserve(source_descriptors.size());
  for (int s = 0; s < static_cast<int>(forward.size()); ++s) {
    const NearestDescriptors& n = forward[s];
    if (n.nearest < 0) continue;
    if (params.mutual_filter && backward[n.nearest].nearest != s) {
      ++stats.rejected_mutual;
      continue;
    }
    // Lowe's test: a match barely closer than the runner-up is ambiguous (repetitive structure, planes).
    // Two identical runners-up (distance 0 to both) are ambiguous too.
    if (ratio_test && std::isfinite(n.second_distance) &&
        !(n.nearest_distance < params.ratio_test * n.second_distance)) {
      ++stats.rejected_ratio;
      continue;
    }
    matches.push_back({s, n.nearest, n.nearest_distance});
  }
  std::stable_sort(matches.begin(), matches.end(),
                   [](const FeatureMatch& a, const FeatureMatch& b) { return a.distance < b.distance; });
  if (matches.size() > params.max_correspondences) {
    stats.truncated = matches.size() - params.max_correspondences;
    matches.resize(params.max_correspondences);
  }
  return matches;
}

std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats,
                                        const StopFlag* stop) {
  return matchFeatures(DescriptorIndex(source), DescriptorIndex(target), params, stats, stop);
}

}  // namespace mac_registration
