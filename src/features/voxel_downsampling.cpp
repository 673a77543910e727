#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "mac_registration/features/voxel_downsampling.hpp"

namespace mac_registration {
namespace {

// 21 bits per axis pack three voxel coordinates into one sortable 64-bit key: 2M voxels along an axis,
// 100 km at 5 cm. (PCL's VoxelGrid has the same kind of bound but answers an overflow by returning the
// input unfiltered with a warning; a front end must not silently skip its downsampling.)
constexpr int kBitsPerAxis = 21;
constexpr std::int64_t kVoxelsPerAxis = std::int64_t(1) << kBitsPerAxis;
// A voxel index is computed in double and cast only within +-2^52, where doubles still hold every integer:
// far inside int64, so neither the cast nor the difference of two indices can overflow, whatever the input.
constexpr double kLargestCellIndex = 4503599627370496.0;  // 2^52

std::int64_t cellIndex(double coordinate, double inverse_voxel_size, double voxel_size) {
  const double cell = std::floor(coordinate * inverse_voxel_size);
  // Also refuses NaN and the Inf of an overflowing product.
  if (!(std::abs(cell) <= kLargestCellIndex)) {
    std::ostringstream reason;
    reason << "a coordinate of " << coordinate << " m lies more than 2^52 voxels of " << voxel_size
           << " m from the origin";
    throw std::invalid_argument(reason.str());
  }
  return static_cast<std::int64_t>(cell);
}

}  // namespace

PointCloud::Ptr voxelDownsample(const PointCloud& cloud, double voxel_size) {
  if (!(voxel_size > 0.0)) throw std::invalid_argument("voxel size must be > 0");
  auto result = pcl::make_shared<PointCloud>();
  if (cloud.empty()) return result;

  const double inverse = 1.0 / voxel_size;
  std::vector<std::int64_t> cells(3 * cloud.size());
  std::int64_t low[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, high[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    const double coordinates[3] = {p.x, p.y, p.z};
    for (int axis = 0; axis < 3; ++axis) {
      const std::int64_t cell = cellIndex(coordinates[axis], inverse, voxel_size);
      cells[3 * i + axis] = cell;
      low[axis] = std::min(low[axis], cell);
      high[axis] = std::max(high[axis], cell);
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    if (high[axis] - low[axis] >= kVoxelsPerAxis) {
      throw std::invalid_argument("the cloud spans " + std::to_string(high[axis] - low[axis] + 1) +
                                  " voxels of " + std::to_string(voxel_size) + " m along an axis (at most " +
                                  std::to_string(kVoxelsPerAxis) + "): raise the voxel size");
    }
  }

  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    std::uint64_t key = 0;
    for (int axis = 0; axis < 3; ++axis)
      key = (key << kBitsPerAxis) | std::uint64_t(cells[3 * i + axis] - low[axis]);
    keyed[i] = {key, static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());

  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin;
    double sum[3] = {0.0, 0.0, 0.0};
    for (; end < keyed.size() && keyed[end].first == keyed[begin].first; ++end) {
      const auto& p = cloud.points[keyed[end].second];
      sum[0] += p.x;
      sum[1] += p.y;
      sum[2] += p.z;
    }
    const double count = double(end - begin);
    result->push_back(pcl::PointXYZ(float(sum[0] / count), float(sum[1] / count), float(sum[2] / count)));
    begin = end;
  }
  result->header = cloud.header;
  result->sensor_origin_ = cloud.sensor_origin_;
  result->sensor_orientation_ = cloud.sensor_orientation_;
  return result;
}

}  // namespace mac_registration
