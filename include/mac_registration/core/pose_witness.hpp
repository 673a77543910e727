#pragma once

// Evidence about a pose from outside the correspondences, given to registerCorrespondences() so that the
// verification decides once, with all of it. The clouds the correspondences came from are one witness
// (features/cloud_verification: does the aligned source lie on the target's surfaces, or in space the
// target's sensor saw through?); a map a scan is placed into can be another.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

class PoseWitness {
 public:
  virtual ~PoseWitness() = default;

  // The signals this witness measures at T_target_source; those it does not measure stay NaN. The
  // verification weighs them with its own evidence terms (verificationEvidence), so a witness reports
  // what it saw, not how much it counts. Called from one thread, and only for a transform that reached
  // the verification: once at the pose the correspondences gave and, where refine() moved it, once more
  // at the fine pose. The expensive part of a witness belongs here, not in its constructor, so that a
  // registration that fails earlier costs nothing more.
  virtual VerificationSignals judge(const Eigen::Isometry3d& T_target_source) const = 0;

  // The pose a fine alignment on this witness's data reaches from T_target_source (a point-to-plane ICP on
  // the clouds), or nothing where it holds no such data. Called at most once per registration, before
  // judge(), and only when verification.fine_alignment is on. How far the fine alignment moved the pose
  // is one of the verification's signals (fine_alignment_move), judge() speaks for both poses (hearWitness
  // in src/core/verification.hpp), and the result carries the fine pose.
  virtual std::optional<FineAlignment> refine(const Eigen::Isometry3d& T_target_source) const {
    (void)T_target_source;
    return std::nullopt;
  }

  // Sentences for result.warnings about what this witness could not use (read after judge()).
  virtual std::vector<std::string> warnings() const { return {}; }
};

}  // namespace mac_registration
