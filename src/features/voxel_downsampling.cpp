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

bool cellInRange(double cell) { return std::abs(cell) <= kLargestCellIndex; }  // false for NaN and Inf

[[noreturn]] void throwCellOutOfRange(double coordinate, double voxel_size) {
  std::ostringstream reason;
  reason << "a coordinate of " << coordinate << " m lies more than 2^52 voxels of " << voxel_size
         << " m from the origin";
  throw std::invalid_argument(reason.str());
}

// Every point's voxel coordinates and their bounding box.
struct Cells {
  std::vector<std::int64_t> xyz;  // 3 per point
  std::int64_t low[3] = {INT64_MAX, INT64_MAX, INT64_MAX};
  std::int64_t high[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
};

Cells computeCells(const PointCloud& cloud, double voxel_size) {
  const double inverse = 1.0 / voxel_size;
  Cells out;
  out.xyz.resize(3 * cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    const double coordinates[3] = {p.x, p.y, p.z};
    for (int axis = 0; axis < 3; ++axis) {
      const double cell = std::floor(coordinates[axis] * inverse);
      if (!cellInRange(cell)) throwCellOutOfRange(coordinates[axis], voxel_size);
      const auto c = static_cast<std::int64_t>(cell);
      out.xyz[3 * i + axis] = c;
      out.low[axis] = std::min(out.low[axis], c);
      out.high[axis] = std::max(out.high[axis], c);
    }
  }
  return out;
}

// A point's voxel as one number, lexicographic in (x, y, z), with its index in the cloud.
struct Keyed {
  std::uint64_t key;
  std::uint32_t index;
};

// Mixed-radix keys over the occupied box: their order is the lexicographic order of the voxels, and they
// need only as many bits as the box has voxels, which bounds the passes of the radix sort below.
std::vector<Keyed> voxelKeys(const Cells& cells, std::size_t n, std::uint64_t& largest_key) {
  const std::uint64_t span_y = std::uint64_t(cells.high[1] - cells.low[1] + 1);
  const std::uint64_t span_z = std::uint64_t(cells.high[2] - cells.low[2] + 1);
  largest_key = (std::uint64_t(cells.high[0] - cells.low[0]) * span_y + (span_y - 1)) * span_z + (span_z - 1);
  std::vector<Keyed> keyed(n);
  const auto count = static_cast<std::int64_t>(n);
  for (std::int64_t i = 0; i < count; ++i) {
    const std::int64_t* c = &cells.xyz[3 * i];
    const std::uint64_t x = std::uint64_t(c[0] - cells.low[0]), y = std::uint64_t(c[1] - cells.low[1]),
                        z = std::uint64_t(c[2] - cells.low[2]);
    keyed[i] = {(x * span_y + y) * span_z + z, static_cast<std::uint32_t>(i)};
  }
  return keyed;
}

// Least-significant-digit radix sort by key, stable: points of one voxel stay in input order, so each
// centroid sums its points in the same order as a comparison sort of (key, index) would.
void radixSortByKey(std::vector<Keyed>& keyed, std::uint64_t largest_key) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t(1) << kDigitBits;
  std::vector<Keyed> buffer(keyed.size());
  for (int shift = 0; shift < 64 && (largest_key >> shift) != 0; shift += kDigitBits) {
    std::vector<std::size_t> start(kBuckets + 1, 0);
    for (const Keyed& k : keyed) ++start[((k.key >> shift) & (kBuckets - 1)) + 1];
    for (std::size_t b = 0; b < kBuckets; ++b) start[b + 1] += start[b];
    for (const Keyed& k : keyed) buffer[start[(k.key >> shift) & (kBuckets - 1)]++] = k;
    keyed.swap(buffer);
  }
}

}  // namespace

PointCloud::Ptr voxelDownsample(const PointCloud& cloud, double voxel_size) {
  if (!(voxel_size > 0.0)) throw std::invalid_argument("voxel size must be > 0");
  auto result = pcl::make_shared<PointCloud>();
  if (cloud.empty()) return result;
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("a cloud of " + std::to_string(cloud.size()) + " points is beyond 2^32");

  const Cells cells = computeCells(cloud, voxel_size);
  for (int axis = 0; axis < 3; ++axis) {
    if (cells.high[axis] - cells.low[axis] >= kVoxelsPerAxis) {
      throw std::invalid_argument("the cloud spans " +
                                  std::to_string(cells.high[axis] - cells.low[axis] + 1) + " voxels of " +
                                  std::to_string(voxel_size) + " m along an axis (at most " +
                                  std::to_string(kVoxelsPerAxis) + "): raise the voxel size");
    }
  }
  std::uint64_t largest_key = 0;
  std::vector<Keyed> keyed = voxelKeys(cells, cloud.size(), largest_key);
  radixSortByKey(keyed, largest_key);

  std::vector<std::size_t> begins;  // where each voxel's run of points starts, then the end
  for (std::size_t i = 0; i < keyed.size(); ++i) {
    if (i == 0 || keyed[i].key != keyed[i - 1].key) begins.push_back(i);
  }
  begins.push_back(keyed.size());
  const auto voxels = static_cast<std::int64_t>(begins.size() - 1);
  result->resize(voxels);
  for (std::int64_t v = 0; v < voxels; ++v) {
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
  result->header = cloud.header;
  result->sensor_origin_ = cloud.sensor_origin_;
  result->sensor_orientation_ = cloud.sensor_orientation_;
  return result;
}

}  // namespace mac_registration
