#pragma once

// The verification of an alignment by the clouds themselves, after the core's verification: the
// correspondences are a few thousand matches, the clouds are what the sensors saw. A right pose lays the
// source's surfaces onto the target's where the two overlap and never into space the other sensor saw
// through; a wrong one puts them across the room, behind the walls, or onto the other side of a street.

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {

// The two clouds as the sensors saw them (keypoints, normals, viewpoints), with their search structures
// built once, so that several poses can be judged cheaply.
class AlignmentJudge {
 public:
  // `tau` [m]: the distance within which an aligned keypoint meets the other cloud's surface, and the
  // margin of the free-space test. `num_threads` 0 = OpenMP's default; the signals do not depend on it.
  // A cloud's viewpoint (features' source_viewpoint / target_viewpoint) is not used where the cloud's
  // nearest keypoint lies more than ten cloud diagonals from it (a world or map frame's origin, not a
  // sensor); that view then gives no free-space or seen-on-surface evidence.
  AlignmentJudge(const FeatureCorrespondences& features, double tau, int num_threads = 0);
  ~AlignmentJudge();

  // One sentence for each cloud whose viewpoint was not used, and why.
  const std::vector<std::string>& viewpointWarnings() const { return viewpoint_warnings_; }

  // The cloud signals of one pose (aligned_overlap, seen_on_surface, surface_agreement,
  // free_space_violation); all NaN when either cloud has fewer than 3 keypoints, seen_on_surface NaN when
  // the target saw fewer than 10 of the aligned source keypoints, surface_agreement NaN without both
  // clouds' keypoint normals or with fewer than 10 aligned keypoints on the target's surfaces.
  VerificationSignals judge(const Eigen::Isometry3d& T_target_source) const;

 private:
  struct View;
  static std::string viewpointNotUsed(const char* role, const View& view);
  std::unique_ptr<View> source_, target_;
  std::vector<std::string> viewpoint_warnings_;
  double tau_;
  int threads_;
};

// The cloud stage of the verification: measures the cloud signals of a result that has a transform,
// merges them into its signals, adds a warning for each viewpoint not used, and decides again
// (decideVerification). Nothing when verification is off
// or the result has no transform. Its time is added to result.times (verification and total).
void verifyAlignment(const FeatureCorrespondences& features, const MacParams& params, MacResult& result);

}  // namespace mac_registration
