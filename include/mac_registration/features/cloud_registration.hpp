#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "mac_registration/config/feature_params.hpp"
#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/feature_matching.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

struct FrontEndStats {
  std::size_t source_points = 0, target_points = 0;        // given
  std::size_t source_dropped = 0, target_dropped = 0;      // NaN/Inf points removed
  std::size_t source_keypoints = 0, target_keypoints = 0;  // after the voxel grid
  // Keypoints without a usable descriptor (too few neighbours for a normal or an FPFH), not matched.
  std::size_t source_no_feature = 0, target_no_feature = 0;
  // Matches removed by the mutual check and by the ratio test, and beyond max_correspondences.
  std::size_t rejected_mutual = 0, rejected_ratio = 0, truncated = 0;
  // [m] mean nearest-neighbour distance of the given clouds, averaged over both; 0 when not estimated
  // (see resolutionNeeded).
  double resolution = 0.0;
  double voxel_size = 0.0;     // [m] the leaf both clouds were described with (features.voxel_size resolved)
  double support_scale = 1.0;  // the factor both clouds' radii were widened by (min_feature_neighbours)
  StageTimes times;            // the front end's stages, source and target together
};

struct FeatureCorrespondences {
  CorrespondenceSet correspondences;  // points and normals of the matched keypoints
  FrontEndStats stats;
  // The keypoints (voxel centroids, finite) and, per correspondence, the index of its keypoint in each:
  // what an evaluation needs to relate the matches to the clouds (e.g. overlap, feature-match recall).
  PointCloud::Ptr source_keypoints, target_keypoints;
  std::vector<int> source_indices, target_indices;
  // The keypoints' normals (oriented towards each cloud's viewpoint) and where the target was seen from:
  // what the verification of an alignment compares.
  pcl::PointCloud<pcl::Normal>::Ptr source_keypoint_normals, target_keypoint_normals;
  Eigen::Vector3f source_viewpoint = Eigen::Vector3f::Zero(), target_viewpoint = Eigen::Vector3f::Zero();
};

// One cloud through the front end up to its descriptors: what matching needs from it. Describing a cloud
// costs most of the front end (normals, FPFH), so a target that stays the same (a map, a keyframe) is
// described once and matched against every new source.
struct DescribedCloud {
  PointCloud::Ptr keypoints;  // voxel centroids that carry a normal and a usable descriptor
  pcl::PointCloud<pcl::Normal>::Ptr normals;
  pcl::PointCloud<pcl::FPFHSignature33>::Ptr descriptors;
  // The search structure over `descriptors`, built by the first match that needs it and shared by copies
  // of this struct: matching a cached target does not index it again. Used only while it indexes these
  // very descriptors (a struct whose descriptors were replaced is indexed afresh at each match).
  std::shared_ptr<const DescriptorIndex> descriptor_index;
  FeatureParams params;  // what it was described with; matching refuses other parameters
  // The factor its radii were widened by (features.min_feature_neighbours; 1 = as given). Two clouds are
  // matched only at the same scale.
  double support_scale = 1.0;
  std::size_t points = 0;      // given
  std::size_t dropped = 0;     // NaN/Inf points removed
  std::size_t voxels = 0;      // keypoints after the voxel grid
  std::size_t no_feature = 0;  // of them, without a normal or a usable descriptor
  double resolution = 0.0;     // [m] mean nearest-neighbour distance of the given cloud, 0 = not estimated
  std::size_t support_points = 0;  // of the FPFH surface (features.support_voxel_factor), with a normal
  // Where the sensor was, in the cloud's frame (its sensor_origin_: a PCD's VIEWPOINT, else the origin).
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();
  StageTimes times;  // describing it: resolution, downsample, normals, features
};

// Whether describeCloud estimates the resolution: only features.gaussian_sigma_resolutions > 0 uses it.
bool resolutionNeeded(const FeatureParams& params);

// Throws std::invalid_argument for invalid params, a cloud with fewer than 3 finite points, or one whose
// coordinates are beyond kMaxAbsCoordinate or so large that float32 spaces them more than a quarter voxel
// apart (the voxel grid and FPFH would see a staircase); `role` ("source", "target") names the cloud in
// that message. All of it is checked before any kd-tree or voxel grid is built. Throws Cancelled when `stop`
// is raised before it is done: it is read between the stages and inside their loops over points, so that a
// shutdown does not wait for the description of a large cloud. `support_scale` > 0 describes it with radii
// widened by that factor (to match a cloud described at it); 0 = the scale its own density needs
// (features.min_feature_neighbours).
DescribedCloud describeCloud(const PointCloud& cloud, const FeatureParams& params, const std::string& role,
                             const StopFlag* stop = nullptr, double support_scale = 0.0);

// Whether `cloud` was described with the voxel size, radii and support factor of `params` (what its
// descriptors depend on); with voxel_size auto (0), any voxel size.
bool describedWith(const DescribedCloud& cloud, const FeatureParams& params);

// Matches two described clouds. Throws std::invalid_argument when they were described with different
// voxel sizes, radii, support scales or support factors, or with other ones than `params` holds; Cancelled
// when `stop` is raised before it is done.
FeatureCorrespondences matchDescribedClouds(const DescribedCloud& source, const DescribedCloud& target,
                                            const FeatureParams& params, const StopFlag* stop = nullptr);

// Clouds in (any frame each, may hold NaNs, may be organized), correspondences out: describeCloud on both
// (with voxel_size auto, the coarser of their autoVoxelSize), then matchDescribedClouds. Throws
// std::invalid_argument for invalid params or a cloud with fewer than 3 finite points, Cancelled when
// `stop` is raised before it is done.
FeatureCorrespondences computeCorrespondences(const PointCloud& source, const PointCloud& target,
                                              const FeatureParams& params, const StopFlag* stop = nullptr);

struct CloudRegistrationResult {
  MacResult registration;  // its inlier indices refer to correspondences below; its times are the core's
  FeatureCorrespondences features;  // stats.times: the front end's

  // The whole registration's, stage by stage: the front end's and the core's.
  StageTimes times() const {
    StageTimes all = features.stats.times;
    all += registration.times;
    return all;
  }
};

// The core's parameters as a cloud registration uses them: graph.gaussian_sigma from
// features.gaussian_sigma_resolutions x the clouds' resolution when that factor is set (and the resolution
// was estimated), and each metric distance given as 0 (auto: graph.gaussian_sigma,
// graph.quadratic_threshold, evaluation.inlier_threshold) from the voxel size the clouds were described
// with (stats.voxel_size; kGaussianSigmaVoxels and its siblings).
MacParams inCloudUnits(const MacParams& mac_params, const FeatureParams& feature_params,
                       const FrontEndStats& stats);

// The voxel size that leaves `cloud` about kAutoVoxelKeypoints keypoints (or half its finite points, for
// a smaller cloud): features.voxel_size = auto. Deterministic; 0 for fewer than 3 finite points.
// Throws Cancelled when `stop` is raised before it is done (read between its three counts).
double autoVoxelSize(const PointCloud& cloud, const StopFlag* stop = nullptr);

// Front end then the MAC core. Never throws: invalid feature parameters come back as a failed
// registration with status kInvalidParameters, unusable clouds with kInvalidInput, each with a message.
// A raised `stop` ends it early, in the front end as in the core, with status kCancelled.
CloudRegistrationResult registerClouds(const PointCloud& source, const PointCloud& target,
                                       const FeatureParams& feature_params, const MacParams& mac_params,
                                       const StopFlag* stop = nullptr);

// The same with the target already described (see DescribedCloud): the source is described here.
CloudRegistrationResult registerCloudToDescribed(const PointCloud& source, const DescribedCloud& target,
                                                 const FeatureParams& feature_params,
                                                 const MacParams& mac_params, const StopFlag* stop = nullptr);

// The same with both clouds described before (a query matched against several places of a map).
CloudRegistrationResult registerDescribedClouds(const DescribedCloud& source, const DescribedCloud& target,
                                                const FeatureParams& feature_params,
                                                const MacParams& mac_params, const StopFlag* stop = nullptr);

// One source against several targets (a place recognizer's top-k loop candidates): the source is
// described once, each target in turn. With voxel_size auto, every cloud is described with the coarsest of
// their autoVoxelSize. A null target fails alone (kInvalidInput). Results in the targets' order; the
// source's description time is in the first one's times only. Never throws.
std::vector<CloudRegistrationResult> registerCandidates(const PointCloud& source,
                                                        const std::vector<PointCloud::ConstPtr>& targets,
                                                        const FeatureParams& feature_params,
                                                        const MacParams& mac_params,
                                                        const StopFlag* stop = nullptr);

// What orders candidates: the successes by confidence, then the others by inliers, each highest first
// (ties: the given order).
struct CandidateRank {
  bool success = false;
  double confidence = 0.0;
  std::size_t inliers = 0;
};
CandidateRank rankOf(const MacResult& result);
std::vector<std::size_t> bestFirst(const std::vector<CandidateRank>& ranks);

}  // namespace mac_registration
