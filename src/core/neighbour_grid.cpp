#include "neighbour_grid.hpp"

#include <limits>

namespace mac_registration {

template <typename Scalar>
NeighbourGrid<Scalar>::NeighbourGrid(const Points& points, double radius) : radius_(radius) {
  const std::size_t n = static_cast<std::size_t>(points.cols());
  Vector3 lo = Vector3::Constant(std::numeric_limits<Scalar>::max());
  Vector3 hi = -lo;
  std::size_t finite = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!points.col(i).allFinite()) continue;
    lo = lo.cwiseMin(points.col(i));
    hi = hi.cwiseMax(points.col(i));
    ++finite;
  }
  origin_ = lo.template cast<double>();
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();
  if (finite > 0) extent = (hi - lo).template cast<double>();
  // A margin over the radius keeps a neighbour within one cell of the query's cell despite the rounding
  // of the cell coordinates; a wider cell keeps spread-out clouds within four cells a point.
  cell_ = radius * 1.001;
  const double max_cells = 4.0 * static_cast<double>(n) + 64.0;
  while ((std::floor(extent.x() / cell_) + 1) * (std::floor(extent.y() / cell_) + 1) *
             (std::floor(extent.z() / cell_) + 1) >
         max_cells)
    cell_ *= 1.25;
  for (int a = 0; a < 3; ++a) dims_[a] = static_cast<int>(std::floor(extent[a] / cell_)) + 1;
  const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  // Counting sort of the points by cell: each cell's points contiguous, in index order.
  start_.assign(cells + 1, 0);
  constexpr std::size_t kNoCell = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> cell_of(n, kNoCell);
  for (std::size_t i = 0; i < n; ++i) {
    if (!points.col(i).allFinite()) continue;
    cell_of[i] = cellIndex(cellOf(points.col(i)));
    ++start_[cell_of[i] + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
  x_.resize(finite);
  y_.resize(finite);
  z_.resize(finite);
  indices_.resize(finite);
  for (std::size_t i = 0; i < n; ++i) {
    if (cell_of[i] == kNoCell) continue;
    const std::size_t slot = fill[cell_of[i]]++;
    x_[slot] = points(0, i);
    y_[slot] = points(1, i);
    z_[slot] = points(2, i);
    indices_[slot] = static_cast<int>(i);
  }
}

template class NeighbourGrid<float>;
template class NeighbourGrid<double>;

}  // namespace mac_registration
