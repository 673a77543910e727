#pragma once

#include <Eigen/Geometry>

#include "evaluation.hpp"
#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

struct RefinementOutcome {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  HypothesisScore score;
  int iterations = 0;    // rounds run
  int improvements = 0;  // rounds that raised the score
};

// Iteratively reweighted SVD on the inliers of the current transform, weights 1 / (1 + (r / tau)^2).
// Stops when a round does not raise the score, or would tip an `initial` within evaluation.max_tilt_deg
// beyond it, and returns the best transform seen, never a worse one than `initial`. A raised `stop` ends
// it after the current round.
RefinementOutcome refineTransform(const Eigen::Isometry3d& initial, const HypothesisScore& initial_score,
                                  const CorrespondenceSet& correspondences,
                                  const HypothesisEvaluator& evaluator, const EvaluationParams& evaluation,
                                  const RefinementParams& params, const StopFlag* stop = nullptr);

}  // namespace mac_registration
