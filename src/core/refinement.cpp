#include "mac_registration/core/refinement.hpp"

#include "mac_registration/core/hypotheses.hpp"

namespace mac_registration {

RefinementOutcome refineTransform(const Eigen::Isometry3d& initial, const HypothesisScore& initial_score,
                                  const CorrespondenceSet& correspondences,
                                  const HypothesisEvaluator& evaluator, const EvaluationParams& evaluation,
                                  const RefinementParams& params, const StopFlag* stop) {
  RefinementOutcome best;
  best.T_target_source = initial;
  best.score = initial_score;
  const double tau = evaluation.inlier_threshold;
  for (int round = 0; round < params.max_iterations && !stopRequested(stop); ++round) {
    best.iterations = round + 1;
    const std::vector<int> inliers = evaluator.inliers(best.T_target_source);
    const std::vector<double> residuals = evaluator.residuals(best.T_target_source);
    std::vector<double> weights(residuals.size(), 0.0);
    for (int i : inliers) weights[i] = 1.0 / (1.0 + (residuals[i] / tau) * (residuals[i] / tau));
    const auto candidate = estimateRigidTransform(correspondences, inliers, weights);
    if (!candidate) break;
    const HypothesisScore score = evaluator.score(*candidate);
    if (!(score.score > best.score.score)) break;
    best.T_target_source = *candidate;
    best.score = score;
    ++best.improvements;
  }
  return best;
}

}  // namespace mac_registration
