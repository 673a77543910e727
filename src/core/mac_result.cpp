#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

const char* toString(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kSuccess:
      return "success";
    case RegistrationStatus::kInvalidParameters:
      return "invalid parameters";
    case RegistrationStatus::kInvalidInput:
      return "invalid input";
    case RegistrationStatus::kTooFewCorrespondences:
      return "too few correspondences";
    case RegistrationStatus::kEmptyGraph:
      return "empty compatibility graph";
    case RegistrationStatus::kNoClique:
      return "no clique";
    case RegistrationStatus::kNoValidHypothesis:
      return "no valid hypothesis";
    case RegistrationStatus::kTooFewInliers:
      return "too few inliers";
    case RegistrationStatus::kInternalError:
      return "internal error";
    case RegistrationStatus::kCancelled:
      return "cancelled";
    case RegistrationStatus::kUnverified:
      return "unverified";
  }
  return "unknown";
}

StageTimes& StageTimes::operator+=(const StageTimes& o) {
  resolution_ms += o.resolution_ms;
  downsample_ms += o.downsample_ms;
  normals_ms += o.normals_ms;
  features_ms += o.features_ms;
  matching_ms += o.matching_ms;
  graph_ms += o.graph_ms;
  second_order_ms += o.second_order_ms;
  clique_search_ms += o.clique_search_ms;
  clique_wait_ms += o.clique_wait_ms;
  selection_ms += o.selection_ms;
  hypotheses_ms += o.hypotheses_ms;
  evaluation_ms += o.evaluation_ms;
  refinement_ms += o.refinement_ms;
  verification_ms += o.verification_ms;
  fine_alignment_ms += o.fine_alignment_ms;
  total_ms += o.total_ms;
  return *this;
}

}  // namespace mac_registration
