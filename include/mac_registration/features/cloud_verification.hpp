#pragma once

// The verification of an alignment by the clouds themselves, a witness heard by the core's verification
// before it decides: the correspondences are a few thousand matches, the clouds are what the sensors saw. A
// right pose lays the source's surfaces onto the target's where the two overlap and never into space the
// other sensor saw through; a wrong one puts them across the room, behind the walls, or onto the other side
// of a street.

#include <Eigen/Geometry>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/core/pose_witness.hpp"
#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {

// The two clouds as the sensors saw them (keypoints, normals, viewpoints), with their search structures
// built once, at the first judge(), so that several poses can be judged cheaply and a registration that
// fails before its verification does not pay for them. Given to registerCorrespondences() as its witness.
class AlignmentJudge : public PoseWitness {
 public:
  // `tau` [m]: the distance within which an aligned keypoint meets the other cloud's surface, and the
  // margin of the free-space test. `num_threads` 0 = OpenMP's default; the signals do not depend on it.
  // A cloud's viewpoint (features' source_viewpoint / target_viewpoint) is not used where the cloud's
  // nearest keypoint lies more than ten cloud diagonals from it (a world or map frame's origin, not a
  // sensor); that view then gives no free-space or seen-on-surface evidence. Nor does a viewpoint that is
  // not finite: a map's, which no single place saw. Keeps the keypoints and
  // normals of `features` (shared pointers), not the rest.
  AlignmentJudge(const FeatureCorrespondences& features, double tau, int num_threads = 0);
  ~AlignmentJudge() override;

  // One sentence for each cloud whose viewpoint was not used, and why.
  std::vector<std::string> warnings() const override;

  // The cloud signals of one pose (aligned_overlap, seen_on_surface, surface_agreement,
  // free_space_violation); all NaN when either cloud has fewer than 3 keypoints, seen_on_surface NaN when
  // the target saw fewer than 10 of the aligned source keypoints, surface_agreement NaN without both
  // clouds' keypoint normals or with fewer than 10 aligned keypoints on the target's surfaces.
  VerificationSignals judge(const Eigen::Isometry3d& T_target_source) const override;

  // Point-to-plane ICP of the source keypoints onto the target's keypoints and normals (pairs within tau,
  // at most 30 steps); nothing without the target's normals or with fewer than 3 keypoints in either cloud.
  std::optional<FineAlignment> refine(const Eigen::Isometry3d& T_target_source) const override;

 private:
  struct View;
  static std::string viewpointNotUsed(const char* role, const View& view);
  // The views and their warnings, once.
  void buildViews() const;

  PointCloud::ConstPtr source_keypoints_, target_keypoints_;
  pcl::PointCloud<pcl::Normal>::ConstPtr source_normals_, target_normals_;
  Eigen::Vector3f source_viewpoint_, target_viewpoint_;
  double tau_;
  int threads_;
  mutable std::once_flag built_;
  mutable std::unique_ptr<View> source_, target_;
  mutable std::vector<std::string> viewpoint_warnings_;
};

}  // namespace mac_registration
