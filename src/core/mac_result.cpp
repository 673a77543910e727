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

}  // namespace mac_registration
