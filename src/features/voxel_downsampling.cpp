#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mac_registration/features/voxel_downsampling.hpp"

namespace mac_registration {
namespace {

// At most 2^21 voxels along an axis (100 km at 5 cm), so that the three voxel coordinates fit one 64-bit
// key. (PCL's VoxelGrid has the same kind of bound but answers an overflow by returning the input
// unfiltered with a warning; a front end must not silently skip its downsampling.)
constexpr int kBitsPerAxis = 21;
constexpr std::int64_t kVoxelsPerAxis = std::int64_t(1) << kBitsPerAxis;
// A voxel index is computed in double and cast only within +-2^52, where doubles still hold every integer:
// far inside int64, so neither the cast nor the difference of two indices can overflow, whatever the input.
constexpr double kLargestCellIndex = 4503599627370496.0;  // 2^52

// Below this many points a parallel pass costs more in thread start-up than it saves.
constexpr std::int64_t kParallelPoints = 1 << 14;
// The passes over the points go by blocks of this many, reading the stop flag once a block (a few tens
// of microseconds): a 5 M-point cloud is a second of voxel grid on two cores, too long to ignore a stop.
constexpr std::int64_t kBlock = 1 << 14;

std::int64_t blocksOf(std::int64_t n) { return (n + kBlock - 1) / kBlock; }

bool cellInRange(double cell) { return std::abs(cell) <= kLargestCellIndex; }  // false for NaN and Inf

[[noreturn]] void throwCellOutOfRange(double coordinate, double voxel_size) {
  std::ostringstream reason;
  reason << "a coordinate of " << coordinate << " m lies more than 2^52 voxels of " << voxel_size
         << " m from the origin";
  throw std::invalid_argument(reason.str());
}

// The occupied box in voxel coordinates. floor(x / voxel) is monotone in x, so the box of the points'
// cells is the cells of the points' box: one min / max pass over the floats, no per-point cell array.
struct CellBox {
  std::int64_t low[3] = {0, 0, 0};
  std::int64_t high[3] = {0, 0, 0};
};

CellBox occupiedBox(const PointCloud& cloud, double voxel_size, int threads, const StopFlag* stop) {
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  bool finite = true;
  const auto n = static_cast<std::int64_t>(cloud.size());
  const std::int64_t blocks = blocksOf(n);
#pragma omp parallel for num_threads(threads) schedule(static) reduction(min : lo[:3]) \
    reduction(max : hi[:3]) reduction(&& : finite) if (n >= kParallelPoints)
  for (std::int64_t b = 0; b < blocks; ++b) {
    if (stopRequested(stop)) continue;
    for (std::int64_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
      const auto& p = cloud.points[i];
      finite = finite && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
      lo[0] = std::min(lo[0], p.x), lo[1] = std::min(lo[1], p.y), lo[2] = std::min(lo[2], p.z);
      hi[0] = std::max(hi[0], p.x), hi[1] = std::max(hi[1], p.y), hi[2] = std::max(hi[2], p.z);
    }
  }
  throwIfStopped(stop, "in the voxel grid");
  if (!finite) {
    for (const auto& p : cloud.points) {
      for (const float c : {p.x, p.y, p.z}) {
        if (!std::isfinite(c)) throwCellOutOfRange(c, voxel_size);
      }
    }
  }
  const double inverse = 1.0 / voxel_size;
  CellBox box;
  for (int axis = 0; axis < 3; ++axis) {
    const double low = std::floor(lo[axis] * inverse), high = std::floor(hi[axis] * inverse);
    if (!cellInRange(low)) throwCellOutOfRange(lo[axis], voxel_size);
    if (!cellInRange(high)) throwCellOutOfRange(hi[axis], voxel_size);
    box.low[axis] = static_cast<std::int64_t>(low);
    box.high[axis] = static_cast<std::int64_t>(high);
  }
  return box;
}

// A point's voxel as one number, lexicographic in (x, y, z), with its index in the cloud.
struct Keyed {
  std::uint64_t key;
  std::uint32_t index;
};

// Mixed-radix keys over the occupied box: their order is the lexicographic order of the voxels, and they
// need only as many bits as the box has voxels, which bounds the passes of the radix sort below.
std::vector<Keyed> voxelKeys(const PointCloud& cloud, double voxel_size, const CellBox& box, int threads,
                             const StopFlag* stop, std::uint64_t& largest_key) {
  const std::uint64_t span_y = std::uint64_t(box.high[1] - box.low[1] + 1);
  const std::uint64_t span_z = std::uint64_t(box.high[2] - box.low[2] + 1);
  largest_key = (std::uint64_t(box.high[0] - box.low[0]) * span_y + (span_y - 1)) * span_z + (span_z - 1);
  const double inverse = 1.0 / voxel_size;
  std::vector<Keyed> keyed(cloud.size());
  const auto n = static_cast<std::int64_t>(cloud.size());
  const auto offset = [&](float coordinate, int axis) {
    return std::uint64_t(static_cast<std::int64_t>(std::floor(coordinate * inverse)) - box.low[axis]);
  };
  const std::int64_t blocks = blocksOf(n);
#pragma omp parallel for num_threads(threads) schedule(static) if (n >= kParallelPoints)
  for (std::int64_t b = 0; b < blocks; ++b) {
    if (stopRequested(stop)) continue;
    for (std::int64_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
      const auto& p = cloud.points[i];
      keyed[i] = {(offset(p.x, 0) * span_y + offset(p.y, 1)) * span_z + offset(p.z, 2),
                  static_cast<std::uint32_t>(i)};
    }
  }
  throwIfStopped(stop, "in the voxel grid");
  return keyed;
}

// Least-significant-digit radix sort by key, stable: points of one voxel stay in input order, so each
// centroid sums its points in the same order as a comparison sort of (key, index) would. Each thread
// counts and moves a contiguous block of the input; the blocks' buckets are laid out in block order, which
// keeps the sort stable and its output the same whatever the thread count.
void radixSortByKey(std::vector<Keyed>& keyed, std::uint64_t largest_key, int threads, const StopFlag* stop) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t(1) << kDigitBits;
  const std::size_t n = keyed.size();
  if (n < std::size_t(kParallelPoints)) threads = 1;
  std::vector<Keyed> buffer(n);
  std::vector<std::size_t> start(kBuckets * threads);
  for (int shift = 0; shift < 64 && (largest_key >> shift) != 0; shift += kDigitBits) {
    throwIfStopped(stop, "in the voxel grid");  // between passes: each is one sweep over the points
    const auto digit = [&](const Keyed& k) { return (k.key >> shift) & (kBuckets - 1); };
#pragma omp parallel num_threads(threads)
    {
      const int blocks = omp_get_num_threads(), b = omp_get_thread_num();
      const std::size_t first = n * b / blocks, last = n * (b + 1) / blocks;
      std::size_t* mine = &start[kBuckets * b];
      std::fill(mine, mine + kBuckets, 0);
      for (std::size_t i = first; i < last; ++i) ++mine[digit(keyed[i])];
#pragma omp barrier
#pragma omp single
      {
        std::size_t sum = 0;
        for (std::size_t d = 0; d < kBuckets; ++d) {
          for (int t = 0; t < blocks; ++t) {
            const std::size_t count = start[kBuckets * t + d];
            start[kBuckets * t + d] = sum;
            sum += count;
          }
        }
      }
      for (std::size_t i = first; i < last; ++i) buffer[mine[digit(keyed[i])]++] = keyed[i];
    }
    keyed.swap(buffer);
  }
}

}  // namespace

PointCloud::Ptr voxelDownsample(const PointCloud& cloud, double voxel_size, int num_threads,
                                const StopFlag* stop) {
  if (!(voxel_size > 0.0)) throw std::invalid_argument("voxel size must be > 0");
  auto result = pcl::make_shared<PointCloud>();
  if (cloud.empty()) return result;
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("a cloud of " + std::to_string(cloud.size()) + " points is beyond 2^32");

  const int threads = num_threads > 0 ? num_threads : omp_get_num_procs();
  const CellBox box = occupiedBox(cloud, voxel_size, threads, stop);
  for (int axis = 0; axis < 3; ++axis) {
    if (box.high[axis] - box.low[axis] >= kVoxelsPerAxis) {
      throw std::invalid_argument("the cloud spans " + std::to_string(box.high[axis] - box.low[axis] + 1) +
                                  " voxels of " + std::to_string(voxel_size) + " m along an axis (at most " +
                                  std::to_string(kVoxelsPerAxis) + "): raise the voxel size");
    }
  }
  std::uint64_t largest_key = 0;
  std::vector<Keyed> keyed = voxelKeys(cloud, voxel_size, box, threads, stop, largest_key);
  radixSortByKey(keyed, largest_key, threads, stop);
  throwIfStopped(stop, "in the voxel grid");

  std::vector<std::size_t> begins;  // where each voxel's run of points starts, then the end
  for (std::size_t i = 0; i < keyed.size(); ++i) {
    if (i == 0 || keyed[i].key != keyed[i - 1].key) begins.push_back(i);
  }
  begins.push_back(keyed.size());
  const auto voxels = static_cast<std::int64_t>(begins.size() - 1);
  result->resize(voxels);
  const std::int64_t blocks = blocksOf(voxels);
#pragma omp parallel for num_threads(threads) schedule(static) if (voxels >= kParallelPoints)
  for (std::int64_t b = 0; b < blocks; ++b) {
    if (stopRequested(stop)) continue;
    for (std::int64_t v = b * kBlock; v < std::min(voxels, (b + 1) * kBlock); ++v) {
      double sum[3] = {0.0, 0.0, 0.0};
      for (std::size_t k = begins[v]; k < begins[v + 1]; ++k) {
        const auto& p = cloud.points[keyed[k].index];
        sum[0] += p.x;
        sum[1] += p.y;
        sum[2] += p.z;
      }
      const double count = double(begins[v + 1] - begins[v]);
      (*result)[v] = pcl::PointXYZ(float(sum[0] / count), float(sum[1] / count), float(sum[2] / count));
    }
  }
  throwIfStopped(stop, "in the voxel grid");
  result->header = cloud.header;
  result->sensor_origin_ = cloud.sensor_origin_;
  result->sensor_orientation_ = cloud.sensor_orientation_;
  return result;
}

}  // namespace mac_registration
