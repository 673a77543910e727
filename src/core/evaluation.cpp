#include "mac_registration/core/evaluation.hpp"

#include <algorithm>
#include <cmath>

namespace mac_registration {

HypothesisEvaluator::HypothesisEvaluator(const Correspondences& c, const EvaluationParams& params)
    : params_(params) {
  const std::size_t n = c.size();
  source_centroid_ = n ? Eigen::Vector3d(c.source_points.rowwise().mean()) : Eigen::Vector3d::Zero();
  target_centroid_ = n ? Eigen::Vector3d(c.target_points.rowwise().mean()) : Eigen::Vector3d::Zero();
  for (auto* v : {&sx_, &sy_, &sz_, &tx_, &ty_, &tz_}) v->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d s = c.source_points.col(i) - source_centroid_;
    const Eigen::Vector3d t = c.target_points.col(i) - target_centroid_;
    sx_[i] = float(s.x()), sy_[i] = float(s.y()), sz_[i] = float(s.z());
    tx_[i] = float(t.x()), ty_[i] = float(t.y()), tz_[i] = float(t.z());
  }
}

HypothesisEvaluator::CentredTransform::CentredTransform(const Eigen::Isometry3d& T, const Eigen::Vector3d& cs,
                                                        const Eigen::Vector3d& ct) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d shift = R * cs + T.translation() - ct;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) r[3 * a + b] = float(R(a, b));
    t[a] = float(shift(a));
  }
}

HypothesisScore HypothesisEvaluator::score(const Eigen::Isometry3d& T) const {
  const CentredTransform m(T, source_centroid_, target_centroid_);
  const float tau = float(params_.inlier_threshold), tau2 = tau * tau;
  const std::size_t n = sx_.size();
  // Branch-free blocks of float sums vectorize; the blocks are added in double, in a fixed order.
  constexpr std::size_t kBlock = 1024;
  double score = 0.0;
  std::size_t inliers = 0;
  for (std::size_t begin = 0; begin < n; begin += kBlock) {
    const std::size_t end = std::min(n, begin + kBlock);
    float block_score = 0.0f;
    int block_inliers = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const float r2 = residualSquared(m, i);
      const bool inlier = r2 < tau2;
      const float closeness = inlier ? (tau - std::sqrt(r2)) / tau : 0.0f;
      block_inliers += inlier;
      block_score += params_.metric == ScoreMetric::kMAE   ? closeness
                     : params_.metric == ScoreMetric::kMSE ? closeness * closeness
                                                           : float(inlier);
    }
    score += block_score;
    inliers += block_inliers;
  }
  return {score, inliers};
}

std::vector<double> HypothesisEvaluator::residuals(const Eigen::Isometry3d& T) const {
  const CentredTransform m(T, source_centroid_, target_centroid_);
  std::vector<double> r(sx_.size());
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = std::sqrt(double(residualSquared(m, i)));
  return r;
}

std::vector<int> HypothesisEvaluator::inliers(const Eigen::Isometry3d& T) const {
  const CentredTransform m(T, source_centroid_, target_centroid_);
  const float tau = float(params_.inlier_threshold), tau2 = tau * tau;
  std::vector<int> indices;
  for (std::size_t i = 0; i < sx_.size(); ++i) {
    if (residualSquared(m, i) < tau2) indices.push_back(static_cast<int>(i));
  }
  return indices;
}

int bestHypothesis(const std::vector<HypothesisScore>& scores) {
  int best = -1;
  for (std::size_t h = 0; h < scores.size(); ++h) {
    if (best == -1 || scores[h].score > scores[best].score) best = static_cast<int>(h);
  }
  return best;
}

}  // namespace mac_registration
