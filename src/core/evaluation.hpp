#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/parameters.hpp"

namespace mac_registration {

struct HypothesisScore {
  double score = 0.0;
  std::size_t inliers = 0;
};

// Scores transforms on every correspondence with the residual r_i = |R s_i + t - t_i| (paper Sec. 3.4):
// MAE, MSE or inlier count over the residuals below tau. Keeps a centred single-precision copy of the
// points, built once, so that scoring thousands of hypotheses is one vectorized pass each; centring keeps
// sub-millimetre precision for map-sized coordinates.
class HypothesisEvaluator {
 public:
  HypothesisEvaluator(const CorrespondenceSet& correspondences, const EvaluationParams& params);

  HypothesisScore score(const Eigen::Isometry3d& T_target_source) const;
  // Indices whose residual is below tau, and the residuals of all correspondences.
  std::vector<int> inliers(const Eigen::Isometry3d& T_target_source) const;
  std::vector<double> residuals(const Eigen::Isometry3d& T_target_source) const;
  // The squares of residuals() into `squared` (resized to size()), each exactly the value whose square
  // root residuals() gives, from one vectorized pass and without an allocation once it has grown.
  void squaredResiduals(const Eigen::Isometry3d& T_target_source, std::vector<double>& squared) const;
  // inliers() into `indices` and, for each of them, the refinement's weight 1 / (1 + (r / scale)^2) with r
  // as residuals() gives it and scale in m, into `weights` (0 for the others; resized to size()). One
  // pass, and no allocation once the vectors have grown: the refinement calls it every round.
  void inlierWeights(const Eigen::Isometry3d& T_target_source, double scale, std::vector<int>& indices,
                     std::vector<double>& weights) const;
  std::size_t size() const { return sx_.size(); }

 private:
  // The transform acting on centred points: R (s - cs) + (R cs + t - ct) is compared with (t_i - ct).
  struct CentredTransform {
    float r[9];
    float t[3];
    CentredTransform(const Eigen::Isometry3d& T, const Eigen::Vector3d& cs, const Eigen::Vector3d& ct);
  };
  float residualSquared(const CentredTransform& m, std::size_t i) const {
    const float dx = m.r[0] * sx_[i] + m.r[1] * sy_[i] + m.r[2] * sz_[i] + m.t[0] - tx_[i];
    const float dy = m.r[3] * sx_[i] + m.r[4] * sy_[i] + m.r[5] * sz_[i] + m.t[1] - ty_[i];
    const float dz = m.r[6] * sx_[i] + m.r[7] * sy_[i] + m.r[8] * sz_[i] + m.t[2] - tz_[i];
    return dx * dx + dy * dy + dz * dz;
  }

  EvaluationParams params_;
  Eigen::Vector3d source_centroid_, target_centroid_;
  std::vector<float> sx_, sy_, sz_, tx_, ty_, tz_;
};

// Whether T keeps the source's z axis within params.max_tilt_deg of the target's (always, at 180).
bool withinTilt(const Eigen::Isometry3d& T, const EvaluationParams& params);

// Index of the highest-scoring hypothesis, the earliest among equals; -1 when there are none.
// Scores are computed in parallel; the choice does not depend on the thread count.
int bestHypothesis(const std::vector<HypothesisScore>& scores);

}  // namespace mac_registration
