#include "hypotheses.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace mac_registration {

std::optional<Eigen::Isometry3d> estimateRigidTransform(const CorrespondenceSet& c,
                                                        const std::vector<int>& indices,
                                                        const std::vector<double>& weights) {
  if (indices.size() < 3) return std::nullopt;
  const auto weight = [&](int i) { return weights.empty() ? 1.0 : weights[i]; };
  double total = 0.0;
  Eigen::Vector3d source_centroid = Eigen::Vector3d::Zero(), target_centroid = Eigen::Vector3d::Zero();
  for (int i : indices) {
    total += weight(i);
    source_centroid += weight(i) * c.source_points.col(i);
    target_centroid += weight(i) * c.target_points.col(i);
  }
  if (!(total > 0.0)) return std::nullopt;
  source_centroid /= total;
  target_centroid /= total;

  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int i : indices) {
    covariance += weight(i) * (c.source_points.col(i) - source_centroid) *
                  (c.target_points.col(i) - target_centroid).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d singular = svd.singularValues();
  // Collinear or coincident points leave the rotation about their line free: refuse instead of guessing.
  if (!(singular(0) > 0.0) || singular(1) < 1e-6 * singular(0)) return std::nullopt;

  Eigen::Matrix3d v = svd.matrixV();
  const Eigen::Matrix3d u = svd.matrixU();
  if ((v * u.transpose()).determinant() < 0.0) v.col(2) *= -1.0;
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = v * u.transpose();
  transform.translation() = target_centroid - transform.linear() * source_centroid;
  if (!transform.matrix().allFinite()) return std::nullopt;
  return transform;
}

std::vector<double> principalEigenvector(const CompatibilityGraph& graph, int iterations,
                                         const StopFlag* stop) {
  const int n = graph.num_nodes;
  std::vector<double> vector(n, 1.0), next(n, 0.0);
  for (int it = 0; it < iterations && !stopRequested(stop); ++it) {
    double largest = 0.0;
    for (int i = 0; i < n; ++i) {
      double sum = 0.0;
      for (auto p = graph.offsets[i]; p < graph.offsets[i + 1]; ++p)
        sum += graph.weights[p] * vector[graph.neighbours[p]];
      next[i] = sum;
      largest = std::max(largest, std::abs(sum));
    }
    if (!(largest > 0.0)) return std::vector<double>(n, 0.0);
    for (int i = 0; i < n; ++i) vector[i] = next[i] / largest;
  }
  return vector;
}

}  // namespace mac_registration
