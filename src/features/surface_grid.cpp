// The grid keeps PCL's float operations in PCL's order (a fused multiply-add would round differently
// from PCL's compiled kd-tree), hence no contraction.
#include <pcl/common/point_tests.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "surface_grid.hpp"

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

}  // namespace

SurfaceGrid::SurfaceGrid(const PointCloud& surface, double radius)
    : squared_radius_(static_cast<float>(radius * radius)) {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  std::size_t finite = 0;  // PCL's kd-tree leaves non-finite points out, and so does the grid
  for (const auto& p : surface) {
    if (!pcl::isFinite(p)) continue;
    lo = lo.cwiseMin(p.getVector3fMap());
    hi = hi.cwiseMax(p.getVector3fMap());
    ++finite;
  }
  origin_ = lo.cast<double>();
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();
  if (finite > 0) extent = (hi - lo).cast<double>();
  // A margin over the radius keeps a neighbour within one cell of the query's cell despite the rounding
  // of the cell coordinates; a wider cell keeps spread-out clouds within four cells a point.
  cell_ = radius * 1.001;
  const double max_cells = 4.0 * static_cast<double>(surface.size()) + 64.0;
  while ((std::floor(extent.x() / cell_) + 1) * (std::floor(extent.y() / cell_) + 1) *
             (std::floor(extent.z() / cell_) + 1) >
         max_cells)
    cell_ *= 1.25;
  for (int a = 0; a < 3; ++a) dims_[a] = static_cast<int>(std::floor(extent[a] / cell_)) + 1;
  const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  // Counting sort of the points by cell: each cell's points contiguous, in index order.
  start_.assign(cells + 1, 0);
  constexpr std::size_t kNoCell = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> cell_of(surface.size(), kNoCell);
  for (std::size_t i = 0; i < surface.size(); ++i) {
    if (!pcl::isFinite(surface[i])) continue;
    cell_of[i] = cellIndex(cellOf(surface[i]));
    ++start_[cell_of[i] + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
  x_.resize(finite);
  y_.resize(finite);
  z_.resize(finite);
  indices_.resize(finite);
  for (std::size_t i = 0; i < surface.size(); ++i) {
    if (cell_of[i] == kNoCell) continue;
    const std::size_t slot = fill[cell_of[i]]++;
    x_[slot] = surface[i].x;
    y_[slot] = surface[i].y;
    z_[slot] = surface[i].z;
    indices_[slot] = static_cast<int>(i);
  }
}

// FLANN's float distance to the point in `slot`, summed in FLANN's order, as a (distance bits, index) key:
// non-negative floats order as their bit patterns, so keys order by distance, then index.
inline std::uint64_t SurfaceGrid::keyOf(const Eigen::Vector3f& q, std::size_t slot, bool& within) const {
  const float dx = q.x() - x_[slot], dy = q.y() - y_[slot], dz = q.z() - z_[slot];
  float d = 0.0f;
  d += dx * dx;
  d += dy * dy;
  d += dz * dz;
  within = d < squared_radius_;
  std::uint32_t bits;
  std::memcpy(&bits, &d, sizeof bits);
  return std::uint64_t{bits} << 32 | static_cast<std::uint32_t>(indices_[slot]);
}

void SurfaceGrid::fromKey(std::uint64_t key, int& index, float& squared_distance) {
  index = static_cast<int>(key & 0xffffffffu);
  const auto bits = static_cast<std::uint32_t>(key >> 32);
  std::memcpy(&squared_distance, &bits, sizeof bits);
}

void SurfaceGrid::search(const pcl::PointXYZ& query, bool sorted, Neighbourhood& out,
                         std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) const {
  if (!pcl::isFinite(query)) {  // PCL gives such a keypoint no neighbours (a NaN descriptor)
    out.indices.clear();
    out.squared_distances.clear();
    return;
  }
  const Eigen::Vector3f q = query.getVector3fMap();
  std::size_t ranges[9][2], candidates = 0, count = 0;
  const int rows = candidateRanges(query, ranges);
  for (int r = 0; r < rows; ++r) candidates += ranges[r][1] - ranges[r][0];
  // Every candidate is written and only those within the radius advance the end: no branch to mispredict.
  keys.resize(candidates);
  for (int r = 0; r < rows; ++r) {
    for (std::size_t s = ranges[r][0]; s < ranges[r][1]; ++s) {
      bool within = false;
      keys[count] = keyOf(q, s, within);
      count += within;
    }
  }
  keys.resize(count);
  if (sorted) sortKeys(keys, scratch);
  out.indices.resize(keys.size());
  out.squared_distances.resize(keys.size());
  for (std::size_t j = 0; j < keys.size(); ++j) fromKey(keys[j], out.indices[j], out.squared_distances[j]);
}

bool SurfaceGrid::nearest(const pcl::PointXYZ& query, int& index, float& squared_distance) const {
  if (!pcl::isFinite(query)) return false;
  const Eigen::Vector3f q = query.getVector3fMap();
  std::size_t ranges[9][2];
  const int rows = candidateRanges(query, ranges);
  // (distance bits, index) keys: their minimum is the nearest point, ties to the lowest index.
  std::uint64_t best = std::numeric_limits<std::uint64_t>::max();
  for (int r = 0; r < rows; ++r) {
    for (std::size_t s = ranges[r][0]; s < ranges[r][1]; ++s) {
      bool within = false;
      const std::uint64_t key = keyOf(q, s, within);
      best = within ? std::min(best, key) : best;
    }
  }
  if (best == std::numeric_limits<std::uint64_t>::max()) return false;
  fromKey(best, index, squared_distance);
  return true;
}

int SurfaceGrid::candidateRanges(const pcl::PointXYZ& query, std::size_t (&ranges)[9][2]) const {
  const Eigen::Vector3i c = cellOf(query);
  int rows = 0;
  for (int z = std::max(c.z() - 1, 0); z <= std::min(c.z() + 1, dims_[2] - 1); ++z) {
    for (int y = std::max(c.y() - 1, 0); y <= std::min(c.y() + 1, dims_[1] - 1); ++y, ++rows) {
      const std::size_t row = cellIndex(Eigen::Vector3i(0, y, z));
      ranges[rows][0] = start_[row + std::max(c.x() - 1, 0)];
      ranges[rows][1] = start_[row + std::min(c.x() + 1, dims_[0] - 1) + 1];
    }
  }
  return rows;
}

Eigen::Vector3i SurfaceGrid::cellOf(const pcl::PointXYZ& p) const {
  Eigen::Vector3i c;
  for (int a = 0; a < 3; ++a) {
    // A query outside the surface's box is clamped next to it: the distances decide.
    const double i = std::floor((static_cast<double>(p.data[a]) - origin_[a]) / cell_);
    c[a] = static_cast<int>(std::min(std::max(i, -1.0), static_cast<double>(dims_[a])));
  }
  return c;
}
std::size_t SurfaceGrid::cellIndex(const Eigen::Vector3i& c) const {
  return (static_cast<std::size_t>(c.z()) * dims_[1] + c.y()) * dims_[0] + c.x();
}

std::vector<Neighbourhood> searchAll(const SurfaceGrid& grid, const PointCloud& queries,
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
      if (!check.stopped()) grid.search(queries[which[j]], sorted, out[which[j]], keys, scratch);
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
