#include "evaluation.hpp"

#include <algorithm>
#include <cmath>

#include "kernels/kernel_sets.hpp"
#include "mac_registration/core/pose_error.hpp"

namespace mac_registration {

bool withinTilt(const Eigen::Isometry3d& T, const EvaluationParams& params) {
  return params.max_tilt_deg >= 180.0 || tiltDeg(T) <= params.max_tilt_deg;
}

HypothesisEvaluator::HypothesisEvaluator(const CorrespondenceSet& c, const EvaluationParams& params)
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

namespace {

struct ScoreSums {
  double mae = 0.0, mse = 0.0;
  std::size_t inliers = 0;
};

// The hot loop of the evaluation (hypotheses x correspondences). Branch-free, all three metrics at once,
// and eight explicit lanes: the compiler vectorizes the sums without reassociating float additions, so
// the result is the same with or without vector units. An AVX2 clone is picked at run time where the CPU
// has it (the same operations, no FMA).
MAC_REGISTRATION_CLONES_AVX2 ScoreSums scoreKernel(const float* sx, const float* sy, const float* sz,
                                                   const float* tx, const float* ty, const float* tz,
                                                   std::size_t n, const float* r, const float* t, float tau) {
  constexpr std::size_t kLanes = 8;
  float mae[kLanes] = {}, mse[kLanes] = {}, count[kLanes] = {};
  const float inv_tau = 1.0f / tau, tau2 = tau * tau;
  const auto add = [&](std::size_t lane, float x, float y, float z, float u, float v, float w) {
    const float dx = r[0] * x + r[1] * y + r[2] * z + t[0] - u;
    const float dy = r[3] * x + r[4] * y + r[5] * z + t[1] - v;
    const float dz = r[6] * x + r[7] * y + r[8] * z + t[2] - w;
    const float r2 = dx * dx + dy * dy + dz * dz;
    // The same test as inliers(): r^2 < tau^2 (sqrt may round a residual just below tau up to tau).
    const float inlier = r2 < tau2 ? 1.0f : 0.0f;
    const float closeness = std::max(tau - std::sqrt(std::min(r2, tau2)), 0.0f) * inv_tau;
    mae[lane] += closeness;
    mse[lane] += closeness * closeness;
    count[lane] += inlier;
  };
  std::size_t i = 0;
  for (; i + kLanes <= n; i += kLanes) {
    for (std::size_t l = 0; l < kLanes; ++l)
      add(l, sx[i + l], sy[i + l], sz[i + l], tx[i + l], ty[i + l], tz[i + l]);
  }
  for (std::size_t l = 0; i < n; ++i, ++l) add(l, sx[i], sy[i], sz[i], tx[i], ty[i], tz[i]);
  ScoreSums sums;
  for (std::size_t l = 0; l < kLanes; ++l) {
    sums.mae += mae[l];
    sums.mse += mse[l];
    sums.inliers += static_cast<std::size_t>(count[l]);
  }
  return sums;
}

// residualSquared() of every correspondence, as doubles (float to double is exact). Branch-free so that
// it vectorizes; the same operations in the same order, without FMA, so the same values on either clone.
MAC_REGISTRATION_CLONES_AVX2 void residualsSquaredKernel(const float* sx, const float* sy, const float* sz,
                                                         const float* tx, const float* ty, const float* tz,
                                                         std::size_t n, const float* r, const float* t,
                                                         double* out) {
  for (std::size_t i = 0; i < n; ++i) {
    const float dx = r[0] * sx[i] + r[1] * sy[i] + r[2] * sz[i] + t[0] - tx[i];
    const float dy = r[3] * sx[i] + r[4] * sy[i] + r[5] * sz[i] + t[1] - ty[i];
    const float dz = r[6] * sx[i] + r[7] * sy[i] + r[8] * sz[i] + t[2] - tz[i];
    out[i] = double(dx * dx + dy * dy + dz * dz);
  }
}

}  // namespace

HypothesisScore HypothesisEvaluator::score(const Eigen::Isometry3d& T) const {
  const CentredTransform m(T, source_centroid_, target_centroid_);
  const ScoreSums sums = scoreKernel(sx_.data(), sy_.data(), sz_.data(), tx_.data(), ty_.data(), tz_.data(),
                                     sx_.size(), m.r, m.t, float(params_.inlier_threshold));
  switch (params_.metric) {
    case ScoreMetric::kMAE:
      return {sums.mae, sums.inliers};
    case ScoreMetric::kMSE:
      return {sums.mse, sums.inliers};
    case ScoreMetric::kInlierCount:
      break;
  }
  return {double(sums.inliers), sums.inliers};
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

void HypothesisEvaluator::squaredResiduals(const Eigen::Isometry3d& T, std::vector<double>& squared) const {
  const CentredTransform m(T, source_centroid_, target_centroid_);
  squared.resize(sx_.size());
  residualsSquaredKernel(sx_.data(), sy_.data(), sz_.data(), tx_.data(), ty_.data(), tz_.data(), sx_.size(),
                         m.r, m.t, squared.data());
}

void HypothesisEvaluator::inlierWeights(const Eigen::Isometry3d& T, double scale, std::vector<int>& indices,
                                        std::vector<double>& weights) const {
  const CentredTransform m(T, source_centroid_, target_centroid_);
  const float tau = float(params_.inlier_threshold), tau2 = tau * tau;
  indices.clear();
  // The residuals in one vectorized pass, into the weights; then each becomes its weight (most are 0).
  weights.resize(sx_.size());
  residualsSquaredKernel(sx_.data(), sy_.data(), sz_.data(), tx_.data(), ty_.data(), tz_.data(), sx_.size(),
                         m.r, m.t, weights.data());
  for (std::size_t i = 0; i < sx_.size(); ++i) {
    const double r2 = weights[i];
    if (!(float(r2) < tau2)) {
      weights[i] = 0.0;
      continue;
    }
    const double scaled = std::sqrt(r2) / scale;
    indices.push_back(static_cast<int>(i));
    weights[i] = 1.0 / (1.0 + scaled * scaled);
  }
}

int bestHypothesis(const std::vector<HypothesisScore>& scores) {
  int best = -1;
  for (std::size_t h = 0; h < scores.size(); ++h) {
    if (best == -1 || scores[h].score > scores[best].score) best = static_cast<int>(h);
  }
  return best;
}

}  // namespace mac_registration
