#pragma once

// Evidence about a pose from outside the correspondences, given to registerCorrespondences() so that the
// verification decides once, with all of it. The clouds the correspondences came from are one witness
// (features/cloud_verification: does the aligned source lie on the target's surfaces, or in space the
// target's sensor saw through?); a map a scan is placed into can be another.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

class PoseWitness {
 public:
  virtual ~PoseWitness() = default;

  // The signals this witness measures at T_target_source; those it does not measure stay NaN. The
  // verification weighs them with its own evidence terms (verificationEvidence), so a witness reports
  // what it saw, not how much it counts. Called at most once per registration, from one thread, and only
  // for a transform that reached the verification: the expensive part of a witness belongs here, not in
  // its constructor, so that a registration that fails earlier costs nothing more.
  virtual VerificationSignals judge(const Eigen::Isometry3d& T_target_source) const = 0;

  // Sentences for result.warnings about what this witness could not use (read after judge()).
  virtual std::vector<std::string> warnings() const { return {}; }
};

}  // namespace mac_registration
