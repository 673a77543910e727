// The neighbour search of the front end's FPFH and normals: PCL's kd-tree radius search, list for list,
// without the tree. Internal to the features library.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// A surface point's neighbours within the radius (itself included), as PCL's kd-tree returns them.
struct Neighbourhood {
  std::vector<int> indices;
  std::vector<float> squared_distances;
};

// Every surface point within a radius of a query, found in a uniform grid of cells at least as wide as
// the radius (the 27 cells around the query's own hold them all). The lists are exactly those of PCL's
// kd-tree: FLANN's float distance ((q - p)_x² + (q - p)_y²) + (q - p)_z², kept when below the float
// radius², ordered by distance and then by index (FLANN's sort). FLANN prunes subtrees by bounds summed
// in float, which could only drop a point within rounding of the radius; this visits every candidate.
class SurfaceGrid {
 public:
  SurfaceGrid(const PointCloud& surface, double radius);

  // The neighbours of `query`, in PCL's order when `sorted` (the weighting sums in it), else in grid order
  // (enough where only the set counts). `keys` and `scratch` are scratch space.
  void search(const pcl::PointXYZ& query, bool sorted, Neighbourhood& out, std::vector<std::uint64_t>& keys,
              std::vector<std::uint64_t>& scratch) const;

  // The nearest surface point within the radius of `query` (its index and squared distance, as search
  // measures them; ties to the lowest index), or false when there is none.
  bool nearest(const pcl::PointXYZ& query, int& index, float& squared_distance) const;

 private:
  // The slot ranges of the (up to) 9 rows of 3 cells around the query's cell; returns how many.
  int candidateRanges(const pcl::PointXYZ& query, std::size_t (&ranges)[9][2]) const;
  std::uint64_t keyOf(const Eigen::Vector3f& q, std::size_t slot, bool& within) const;
  static void fromKey(std::uint64_t key, int& index, float& squared_distance);
  Eigen::Vector3i cellOf(const pcl::PointXYZ& p) const;
  std::size_t cellIndex(const Eigen::Vector3i& c) const;

  float squared_radius_;  // PCL's KdTreeFLANN: static_cast<float>(radius * radius)
  Eigen::Vector3d origin_;
  double cell_ = 1.0;
  int dims_[3] = {1, 1, 1};
  std::vector<std::size_t> start_;  // cell c's points are slots start_[c] .. start_[c + 1] - 1
  std::vector<float> x_, y_, z_;
  std::vector<int> indices_;
};

// The neighbourhoods of the queries `which` (the others stay empty), on `threads` threads. Throws
// Cancelled when `stop` is raised before it is done.
std::vector<Neighbourhood> searchAll(const SurfaceGrid& grid, const PointCloud& queries,
                                     const std::vector<int>& which, bool sorted, int threads,
                                     const StopFlag* stop);

// 0, 1, ..., n - 1.
std::vector<int> allIndices(std::size_t n);

}  // namespace mac_registration
