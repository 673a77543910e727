// The neighbour search of the front end's FPFH, normals and cloud verification: PCL's kd-tree radius
// search, list for list, on the package's neighbour grid (src/core/neighbour_grid.hpp) instead of the
// tree. Internal to the features library.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/point_cloud.hpp"
#include "neighbour_grid.hpp"

namespace mac_registration {

using CloudGrid = NeighbourGrid<float>;

// The grid of a cloud's points within `radius` [m]; its indices are the cloud's.
CloudGrid cloudGrid(const PointCloud& cloud, double radius);

// A surface point's neighbours within the radius (itself included), as PCL's kd-tree returns them.
struct Neighbourhood {
  std::vector<int> indices;
  std::vector<float> squared_distances;
};

// The neighbours of `query` in `grid`, exactly PCL's kd-tree lists: FLANN's float distance
// ((q - p)_x² + (q - p)_y²) + (q - p)_z², kept when below the float radius², ordered by distance and then
// by index (FLANN's sort) when `sorted` (the weighting sums in that order), else in grid order (enough
// where only the set counts). FLANN prunes subtrees by bounds summed in float, which could only drop a
// point within rounding of the radius; this visits every candidate. `keys` and `scratch` are scratch space.
void radiusSearch(const CloudGrid& grid, const pcl::PointXYZ& query, bool sorted, Neighbourhood& out,
                  std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch);

// The nearest point of `grid` within its radius of `query` (its index and squared distance, as
// radiusSearch measures them; ties to the lowest index), or false when there is none.
bool nearestWithin(const CloudGrid& grid, const pcl::PointXYZ& query, int& index, float& squared_distance);

// The neighbourhoods of the queries `which` (the others stay empty), on `threads` threads. Throws
// Cancelled when `stop` is raised before it is done.
std::vector<Neighbourhood> searchAll(const CloudGrid& grid, const PointCloud& queries,
                                     const std::vector<int>& which, bool sorted, int threads,
                                     const StopFlag* stop);

// 0, 1, ..., n - 1.
std::vector<int> allIndices(std::size_t n);

}  // namespace mac_registration
