#include "refinement.hpp"

#include "hypotheses.hpp"

namespace mac_registration {

RefinementOutcome refineTransform(const Eigen::Isometry3d& initial, const HypothesisScore& initial_score,
                                  const CorrespondenceSet& correspondences,
                                  const HypothesisEvaluator& evaluator, const EvaluationParams& evaluation,
                                  const RefinementParams& params, const StopFlag* stop) {
  RefinementOutcome best;
  best.T_target_source = initial;
  best.score = initial_score;
  const double tau = evaluation.inlier_threshold;
  // Grown once, reused every round.
  std::vector<int> inliers;
  std::vector<double> weights;
  inliers.reserve(evaluator.size());
  weights.reserve(evaluator.size());
  // An upright start stays upright; a tipped one (a rival judged beside the answer) refines as before.
  const bool upright = withinTilt(initial, evaluation);
  for (int round = 0; round < params.max_iterations && !stopRequested(stop); ++round) {
    best.iterations = round + 1;
    evaluator.inlierWeights(best.T_target_source, tau, inliers, weights);
    const auto candidate = estimateRigidTransform(correspondences, inliers, weights);
    // A refit that tips an upright source beyond the prior is no better a pose, whatever it scores.
    if (!candidate || (upright && !withinTilt(*candidate, evaluation))) break;
    const HypothesisScore score = evaluator.score(*candidate);
    if (!(score.score > best.score.score)) break;
    best.T_target_source = *candidate;
    best.score = score;
    ++best.improvements;
  }
  return best;
}

}  // namespace mac_registration
