#include "mac_registration/features/feature_matching.hpp"

#include <omp.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

#include "kernels/kernel_table.hpp"

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

using kernels::BestTwo;
using kernels::kBins;
using kernels::kLanes;
using kernels::kQueryGroup;
using kernels::ScanState;
using kernels::ScanTiles;
static_assert(kLanes == DescriptorIndex::kPackedLanes && kBins == DescriptorIndex::kDimensions,
              "the scan kernels read DescriptorIndex::Packed");
static_assert(sizeof(pcl::FPFHSignature33::histogram) == kBins * sizeof(float), "FPFH has 33 bins");
// Queries an OpenMP chunk holds (their best stays in L1), and targets scanned before the next group of
// queries (kTargetChunkTiles * 33 * 16 floats = 135 KB: stays in L2 across the chunk's queries).
constexpr int kQueryChunk = 64;
constexpr int kTargetChunkTiles = 64;

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
  static const ScanTiles scan = kernels::activeKernels().descriptor_scan.run;
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
