#pragma once

// The exact descriptor scan of the feature matching: groups of FPFH queries against tiles of packed target
// descriptors (33 bins x 16 lanes a tile, the layout of DescriptorIndex::Packed), keeping each query's
// two nearest and, for the mutual check, each target's nearest query. Every variant keeps the same
// distances (the direct sum, bin by bin, no contraction), so the same matches bit for bit.

#include <limits>

#include "kernel_sets.hpp"

namespace mac_registration {
namespace kernels {

constexpr int kLanes = 16;  // descriptors a tile
constexpr int kBins = 33;   // FPFH histogram bins
// Queries scanned together against one tile: each loaded tile row serves this many queries.
constexpr int kQueryGroup = 8;

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

// Scans tiles [tile_begin, tile_end) of `packed` for the first `distinct_queries` queries of the group.
using ScanTiles = void (*)(const ScanState& s, const float* packed, int tile_begin, int tile_end,
                           int distinct_queries);

void scanTilesPortable(const ScanState& s, const float* packed, int tile_begin, int tile_end,
                       int distinct_queries);
#if MAC_REGISTRATION_X86
void scanTilesAvx2(const ScanState& s, const float* packed, int tile_begin, int tile_end,
                   int distinct_queries);
void scanTilesAvx512(const ScanState& s, const float* packed, int tile_begin, int tile_end,
                     int distinct_queries);
#endif

}  // namespace kernels
}  // namespace mac_registration
