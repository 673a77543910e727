// The search keeps PCL's float operations in PCL's order (a fused multiply-add would round differently
// from PCL's compiled kd-tree), hence no contraction.
#include <pcl/common/point_tests.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "radius_search.hpp"

#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace mac_registration {
namespace {

// Ascending, by a radix sort over the bytes that differ between the keys: a comparison sort of the
// ~100 keys of a neighbourhood spends most of its time on mispredicted branches.
void sortKeys(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) {
  const std::size_t n = keys.size();
  if (n < 32) {
    std::sort(keys.begin(), keys.end());
    return;
  }
  std::uint64_t any = 0, all = ~std::uint64_t{0};
  for (const std::uint64_t k : keys) {
    any |= k;
    all &= k;
  }
  const std::uint64_t varying = any ^ all;
  scratch.resize(n);
  std::uint64_t* from = keys.data();
  std::uint64_t* to = scratch.data();
  for (int shift = 0; shift < 64; shift += 8) {
    if (((varying >> shift) & 0xffu) == 0) continue;
    std::uint32_t start[256] = {};
    for (std::size_t i = 0; i < n; ++i) ++start[(from[i] >> shift) & 0xffu];
    std::uint32_t sum = 0;
    for (std::uint32_t& s : start) {
      const std::uint32_t c = s;
      s = sum;
      sum += c;
    }
    for (std::size_t i = 0; i < n; ++i) to[start[(from[i] >> shift) & 0xffu]++] = from[i];
    std::swap(from, to);
  }
  if (from != keys.data()) std::copy(from, from + n, keys.data());
}

// FLANN's float distance from `q` to the point in `slot`, summed in FLANN's order, as a (distance bits,
// index) key: non-negative floats order as their bit patterns, so keys order by distance, then index.
inline std::uint64_t keyOf(const CloudGrid& grid, const Eigen::Vector3f& q, std::size_t slot,
                           float squared_radius, bool& within) {
  const float dx = q.x() - grid.x(slot), dy = q.y() - grid.y(slot), dz = q.z() - grid.z(slot);
  float d = 0.0f;
  d += dx * dx;
  d += dy * dy;
  d += dz * dz;
  within = d < squared_radius;
  std::uint32_t bits;
  std::memcpy(&bits, &d, sizeof bits);
  return std::uint64_t{bits} << 32 | static_cast<std::uint32_t>(grid.index(slot));
}

void fromKey(std::uint64_t key, int& index, float& squared_distance) {
  index = static_cast<int>(key & 0xffffffffu);
  const auto bits = static_cast<std::uint32_t>(key >> 32);
  std::memcpy(&squared_distance, &bits, sizeof bits);
}

// PCL's KdTreeFLANN compares with the radius squared in double, rounded to float.
float squaredRadiusOf(const CloudGrid& grid) { return static_cast<float>(grid.radius() * grid.radius()); }

}  // namespace

CloudGrid cloudGrid(const PointCloud& cloud, double radius) {
  // A PCL point is 4 floats: x, y, z and padding.
  static_assert(sizeof(pcl::PointXYZ) == 4 * sizeof(float),
                "pcl::PointXYZ is x, y, z and a float of padding");
  return CloudGrid(CloudGrid::Points(reinterpret_cast<const float*>(cloud.points.data()), 3,
                                     static_cast<Eigen::Index>(cloud.size()), Eigen::OuterStride<>(4)),
                   radius);
}

void radiusSearch(const CloudGrid& grid, const pcl::PointXYZ& query, bool sorted, Neighbourhood& out,
                  std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) {
  if (!pcl::isFinite(query)) {  // PCL gives such a keypoint no neighbours (a NaN descriptor)
    out.indices.clear();
    out.squared_distances.clear();
    return;
  }
  const Eigen::Vector3f q = query.getVector3fMap();
  const float squared_radius = squaredRadiusOf(grid);
  std::size_t ranges[9][2], candidates = 0, count = 0;
  const int rows = grid.candidateRanges(q, ranges);
  for (int r = 0; r < rows; ++r) candidates += ranges[r][1] - ranges[r][0];
  // Every candidate is written and only those within the radius advance the end: no branch to mispredict.
  keys.resize(candidates);
  for (int r = 0; r < rows; ++r) {
    for (std::size_t s = ranges[r][0]; s < ranges[r][1]; ++s) {
      bool within = false;
      keys[count] = keyOf(grid, q, s, squared_radius, within);
      count += within;
    }
  }
  keys.resize(count);
  if (sorted) sortKeys(keys, scratch);
  out.indices.resize(keys.size());
  out.squared_distances.resize(keys.size());
  for (std::size_t j = 0; j < keys.size(); ++j) fromKey(keys[j], out.indices[j], out.squared_distances[j]);
}

bool nearestWithin(const CloudGrid& grid, const pcl::PointXYZ& query, int& index, float& squared_distance) {
  if (!pcl::isFinite(query)) return false;
  const Eigen::Vector3f q = query.getVector3fMap();
  const float squared_radius = squaredRadiusOf(grid);
  std::size_t ranges[9][2];
  const int rows = grid.candidateRanges(q, ranges);
  // (distance bits, index) keys: their minimum is the nearest point, ties to the lowest index.
  std::uint64_t best = std::numeric_limits<std::uint64_t>::max();
  for (int r = 0; r < rows; ++r) {
    for (std::size_t s = ranges[r][0]; s < ranges[r][1]; ++s) {
      bool within = false;
      const std::uint64_t key = keyOf(grid, q, s, squared_radius, within);
      best = within ? std::min(best, key) : best;
    }
  }
  if (best == std::numeric_limits<std::uint64_t>::max()) return false;
  fromKey(best, index, squared_distance);
  return true;
}

std::vector<Neighbourhood> searchAll(const CloudGrid& grid, const PointCloud& queries,
                                     const std::vector<int>& which, bool sorted, int threads,
                                     const StopFlag* stop) {
  std::vector<Neighbourhood> out(queries.size());
  const int n = static_cast<int>(which.size());
#pragma omp parallel num_threads(threads)
  {
    std::vector<std::uint64_t> keys, scratch;
    StopCheck check(stop);
#pragma omp for schedule(dynamic, 64)
    for (int j = 0; j < n; ++j) {
      if (!check.stopped()) radiusSearch(grid, queries[which[j]], sorted, out[which[j]], keys, scratch);
    }
  }
  throwIfStopped(stop, "searching neighbourhoods");
  return out;
}

std::vector<int> allIndices(std::size_t n) {
  std::vector<int> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<int>(i);
  return out;
}

}  // namespace mac_registration
