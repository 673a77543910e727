#include "fine_alignment.hpp"

#include <omp.h>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <vector>

#include "mac_registration/core/pose_error.hpp"
#include "verification.hpp"

namespace mac_registration {
namespace {

// The normal equations of one pass: J^T J (6 x 6, rotation then translation) and J^T r of the pairs'
// point-to-plane residuals, and what the pairs were.
struct NormalEquations {
  Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> Jtr = Eigen::Matrix<double, 6, 1>::Zero();
  double squared_residuals = 0.0;
  std::size_t considered = 0;  // source keypoints looked at (every one, or every k-th of a large cloud)
  std::size_t pairs = 0;
  Eigen::Vector3d paired_sum = Eigen::Vector3d::Zero();  // the paired source points, in the source frame
  Eigen::Matrix3d paired_outer = Eigen::Matrix3d::Zero();

  NormalEquations& operator+=(const NormalEquations& o) {
    JtJ += o.JtJ;
    Jtr += o.Jtr;
    squared_residuals += o.squared_residuals;
    pairs += o.pairs;
    paired_sum += o.paired_sum;
    paired_outer += o.paired_outer;
    return *this;
  }
};

// Sums are taken over fixed blocks of the source, then the blocks in order: the same doubles whatever
// the thread count.
constexpr int kBlocks = 64;

// Source keypoints paired at most: every k-th of a larger cloud (a lidar scan's 10-20 thousand), evenly
// over its order, so that a step costs what a 3DMatch fragment's (4-5 thousand keypoints) does; six
// unknowns are fixed long before that.
constexpr int kMostPaired = 5000;

// The steps turn about `centre` (in the target frame), the paired points' middle at the start: turned about
// the frame's origin instead, a cloud kilometres from it (a map in a survey frame) would couple every
// rotation with a large translation, and the normal equations would be too ill-conditioned to step in.
NormalEquations linearise(const PointCloud& source, const PointCloud& target,
                          const pcl::PointCloud<pcl::Normal>& normals, const CloudGrid& grid,
                          const Eigen::Isometry3d& T, const Eigen::Vector3d& centre, int threads) {
  const Eigen::Isometry3f Tf = T.cast<float>();
  const int stride = std::max(1, int((source.size() + kMostPaired - 1) / kMostPaired));
  const int n = int((source.size() + stride - 1) / stride);  // the paired: source[k * stride]
  std::vector<NormalEquations> blocks(kBlocks);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (int b = 0; b < kBlocks; ++b) {
    NormalEquations& e = blocks[b];
    const int end = int((long(n) * (b + 1)) / kBlocks);
    for (int k = int((long(n) * b) / kBlocks); k < end; ++k) {
      const int i = k * stride;
      pcl::PointXYZ q;
      q.getVector3fMap() = Tf * source[i].getVector3fMap();
      int nearest = 0;
      float squared = 0.0f;
      if (!nearestWithin(grid, q, nearest, squared)) continue;
      const Eigen::Vector3d normal = normals[nearest].getNormalVector3fMap().cast<double>();
      if (!normal.allFinite() || normal.squaredNorm() < 0.5) continue;
      const Eigen::Vector3d p = source[i].getVector3fMap().cast<double>();
      const Eigen::Vector3d moved = T * p;
      const double residual = normal.dot(moved - target[nearest].getVector3fMap().cast<double>());
      Eigen::Matrix<double, 6, 1> J;
      J << (moved - centre).cross(normal), normal;
      e.JtJ.selfadjointView<Eigen::Upper>().rankUpdate(J);
      e.Jtr += J * residual;
      e.squared_residuals += residual * residual;
      ++e.pairs;
      e.paired_sum += p;
      e.paired_outer += p * p.transpose();
    }
  }
  NormalEquations total;
  for (const NormalEquations& e : blocks) total += e;
  total.considered = std::size_t(n);
  total.JtJ = total.JtJ.selfadjointView<Eigen::Upper>();
  return total;
}

PointMoments momentsOf(const NormalEquations& e) {
  PointMoments m;
  if (e.pairs == 0) return m;
  m.mean = e.paired_sum / double(e.pairs);
  m.second = e.paired_outer / double(e.pairs);
  return m;
}

// A step moving the paired points by less than this share of the pairing distance (RMS) ends the
// iterations: far below the keypoints' own spacing.
constexpr double kConvergedShare = 1e-3;

// Fewest pairs for a step: six unknowns, and a few pairs more than that so that one surface patch
// cannot drive it.
constexpr std::size_t kFewestPairs = 12;

// The covariance of the pose T from the last linearisation, in the source frame: the steps perturb T on
// the left, in the target frame turned about `centre` (rotation, then translation), with covariance the
// residual variance times the inverse of J^T J; a motion d_c about the centre is d_s = Ad(T^-1 C) d_c on the
// right (C: the translation to the centre), which, in the order (translation, rotation), is
// [R^T, -R^T [t - c]x; 0, R^T] d_c. Directions the surfaces leave free (eigenvalues below a billionth of
// the largest) get kFreeVariance instead of the rounding noise an inverse would give them.
constexpr double kFreeVariance = 1e6;

Eigen::Matrix<double, 6, 6> poseCovariance(const NormalEquations& e, const Eigen::Isometry3d& T,
                                           const Eigen::Vector3d& centre) {
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity() * kFreeVariance;
  if (e.pairs <= 6) return covariance;
  const double variance = e.squared_residuals / double(e.pairs - 6);
  // J^T J is symmetric and positive semi-definite: its singular vectors are its eigenvectors. (Jacobi
  // rotations rather than Eigen's tridiagonalising solver, which GCC 12 for 64-bit ARM warns about.)
  const Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> eigen(e.JtJ, Eigen::ComputeFullU);
  const Eigen::Matrix<double, 6, 1> values = eigen.singularValues();
  const double largest = values.maxCoeff();
  Eigen::Matrix<double, 6, 1> inverse;
  Eigen::Matrix<double, 6, 1> free_direction;
  for (int k = 0; k < 6; ++k) {
    const bool fixed = largest > 0.0 && values[k] > 1e-9 * largest;
    inverse[k] = fixed ? variance / values[k] : 0.0;
    free_direction[k] = fixed ? 0.0 : 1.0;
  }
  Eigen::Matrix<double, 6, 6> swap =
      Eigen::Matrix<double, 6, 6>::Zero();  // (rotation, translation) -> (translation, rotation)
  swap.block<3, 3>(0, 3).setIdentity();
  swap.block<3, 3>(3, 0).setIdentity();
  const Eigen::Matrix3d Rt = T.linear().transpose();
  const Eigen::Vector3d t = T.translation() - centre;
  Eigen::Matrix3d t_cross;
  t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  Eigen::Matrix<double, 6, 6> to_source = Eigen::Matrix<double, 6, 6>::Zero();
  to_source.block<3, 3>(0, 0) = Rt;
  to_source.block<3, 3>(0, 3) = -Rt * t_cross;
  to_source.block<3, 3>(3, 3) = Rt;
  const Eigen::Matrix<double, 6, 6> map = to_source * swap * eigen.matrixU();
  covariance = map * inverse.asDiagonal() * map.transpose();
  // A free direction, mapped the same way, gets kFreeVariance along it.
  covariance += map * (free_direction * kFreeVariance).asDiagonal() * map.transpose();
  return covariance;
}

}  // namespace

FineAlignment alignPointToPlane(const PointCloud& source, const PointCloud& target,
                                const pcl::PointCloud<pcl::Normal>& target_normals,
                                const CloudGrid& target_grid, const Eigen::Isometry3d& start,
                                int max_iterations, int threads) {
  FineAlignment out;
  out.ran = true;
  out.start = start;
  Eigen::Isometry3d T = start;
  const double distance = target_grid.radius();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  NormalEquations e = linearise(source, target, target_normals, target_grid, T, centre, threads);
  if (e.pairs > 0) {
    centre = T * momentsOf(e).mean;
    e = linearise(source, target, target_normals, target_grid, T, centre, threads);
  }
  for (int iteration = 0; iteration < max_iterations && e.pairs >= kFewestPairs; ++iteration) {
    // A damping of a millionth of the mean curvature keeps a direction the surfaces leave free (a
    // corridor's length, a floor's plane) where it is instead of letting rounding slide it.
    Eigen::Matrix<double, 6, 6> H = e.JtJ;
    H.diagonal().array() += 1e-6 * H.trace() / 6.0;
    const Eigen::Matrix<double, 6, 1> x = H.ldlt().solve(-e.Jtr);
    if (!x.allFinite()) break;
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    const double angle = x.head<3>().norm();
    if (angle > 0.0) step.linear() = Eigen::AngleAxisd(angle, x.head<3>() / angle).toRotationMatrix();
    step.translation() = x.tail<3>();
    const Eigen::Isometry3d next = Eigen::Translation3d(centre) * step * Eigen::Translation3d(-centre) * T;
    const double moved = rmsDisplacement(next, T, momentsOf(e));
    T = next;
    out.iterations = iteration + 1;
    e = linearise(source, target, target_normals, target_grid, T, centre, threads);
    if (moved < kConvergedShare * distance) {
      out.converged = true;
      break;
    }
  }
  out.T_target_source = T;
  out.fitness = e.considered > 0 ? double(e.pairs) / double(e.considered) : 0.0;
  out.rmse = e.pairs > 0 ? std::sqrt(e.squared_residuals / double(e.pairs)) : 0.0;
  out.rotation_deg = rotationErrorDeg(start, T);
  out.translation_m = (start.translation() - T.translation()).norm();
  out.displacement = rmsDisplacement(start, T, momentsOf(e));
  out.covariance = poseCovariance(e, T, centre);
  return out;
}

}  // namespace mac_registration
