// The package's one answer to "which points lie within a radius of this one": the front end's neighbour
// lists (normals, FPFH and the cloud verification, in float, through src/features/radius_search.hpp,
// which reads them in PCL's kd-tree order) and the verification's chance level (in double). Each caller
// measures the distances itself, in the precision and order its results depend on; the grid only says
// where to look.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace mac_registration {

// A uniform grid of cells at least as wide as the radius: the 27 cells around a query's own hold every
// point within the radius of it. The cells cover the points' box, each cell's points contiguous and in
// index order, so that the 27 cells are 9 runs of 3 (one per row along x). The cells are widened where
// the box would need more than about four a point (a spread-out cloud), which costs time, never a point.
template <typename Scalar>
class NeighbourGrid {
 public:
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  // The points as the columns of a 3 x n map with any stride between columns: a PCL cloud's floats
  // (4 to a point) or an Eigen Matrix3Xd (3).
  using Points = Eigen::Map<const Eigen::Matrix<Scalar, 3, Eigen::Dynamic>, 0, Eigen::OuterStride<>>;

  // Non-finite points are left out, as PCL's kd-tree leaves them out.
  NeighbourGrid(const Points& points, double radius);

  double radius() const { return radius_; }

  // The slot ranges [ranges[r][0], ranges[r][1]) of the (up to) 9 rows of 3 cells around the query's
  // cell, in grid order; returns how many. They hold every point within the radius of `query`, and
  // others. A query outside the points' box is clamped next to it: the distances decide.
  int candidateRanges(const Vector3& query, std::size_t (&ranges)[9][2]) const {
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

  // The point in a slot, a coordinate at a time, and its column among the points given.
  Scalar x(std::size_t slot) const { return x_[slot]; }
  Scalar y(std::size_t slot) const { return y_[slot]; }
  Scalar z(std::size_t slot) const { return z_[slot]; }
  int index(std::size_t slot) const { return indices_[slot]; }

 private:
  template <typename Point>
  Eigen::Vector3i cellOf(const Point& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      const double i = std::floor((static_cast<double>(p[a]) - origin_[a]) / cell_);
      c[a] = static_cast<int>(std::min(std::max(i, -1.0), static_cast<double>(dims_[a])));
    }
    return c;
  }
  std::size_t cellIndex(const Eigen::Vector3i& c) const {
    return (static_cast<std::size_t>(c.z()) * dims_[1] + c.y()) * dims_[0] + c.x();
  }

  double radius_;
  Eigen::Vector3d origin_;
  double cell_ = 1.0;
  int dims_[3] = {1, 1, 1};
  std::vector<std::size_t> start_;  // cell c's points are slots start_[c] .. start_[c + 1] - 1
  std::vector<Scalar> x_, y_, z_;
  std::vector<int> indices_;
};

extern template class NeighbourGrid<float>;
extern template class NeighbourGrid<double>;

}  // namespace mac_registration
