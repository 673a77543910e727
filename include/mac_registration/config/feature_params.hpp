#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace mac_registration {

// The PCL front end: voxel downsampling, normals, FPFH, matching in feature space. Distances derive from
// one voxel size, so a preset changes one number for a new sensor. This header holds no PCL type, so
// that tools built without PCL can still read and write these parameters.
struct FeatureParams {
  // [m], >= 0: voxel grid leaf, the keypoint spacing. 0 = auto: the leaf that leaves a cloud about
  // kAutoVoxelKeypoints keypoints (autoVoxelSize), the coarser of the two clouds' when a pair is
  // registered, the target's when the target was described before.
  double voxel_size = 0.05;
  double normal_radius_factor = 2.0;   // normal estimation radius = factor x voxel_size, > 0
  double feature_radius_factor = 5.0;  // FPFH radius = factor x voxel_size, > normal_radius_factor
  // [keypoints], 0 = off: the fewest keypoints the median keypoint's FPFH sphere holds. Where a cloud is
  // sparser (16/32-beam lidar, downsampled keyframes), both radii above grow by the same scale, in steps
  // of a quarter octave, up to kMaxSupportScale; the two clouds of a pair are described at the larger of
  // their scales, so that their descriptors stay comparable.
  std::size_t min_feature_neighbours = 0;
  std::size_t max_correspondences = 5000;  // [count], >= 3: keep the best-matching ones (feature distance)
  bool mutual_filter = false;              // keep only mutual nearest neighbours in feature space
  double ratio_test = 0.0;  // Lowe's ratio in (0, 1), 0 = off: nearest / second nearest distance
  // The surface each FPFH sums over: a voxel grid of the keypoints with leaf factor x voxel_size, in
  // [1, feature_radius_factor). 1 = the keypoints themselves (PCL's FPFH at every keypoint); a coarser
  // surface holds fewer points in each keypoint's radius (their count scales with the area: 1/factor^2).
  double support_voxel_factor = 1.0;
  // Approximation of the descriptor search, >= 0, 0 = exact: the match found is at most (1 + epsilon)
  // times farther than the nearest descriptor (FLANN's kd-tree eps). 0 is an exact brute-force search,
  // about as fast as the kd-tree with eps 1 on 5 000-19 000 descriptors; eps > 0 keeps the kd-tree.
  double match_epsilon = 0.0;
  int num_threads = 0;  // 0 = OpenMP default
  // d_cmp of the Gaussian compatibility score in resolution units (mean nearest-neighbour distance of
  // the given clouds), 0 = off: registerClouds then uses graph.gaussian_sigma [m] as given. The paper
  // uses 10. Only clouds have a resolution, so correspondence-only callers always give metres.
  double gaussian_sigma_resolutions = 0.0;
  // Most query points the resolution is estimated from [count], >= 100: a deterministic even subsample
  // of each cloud, each searched against the whole cloud (the mean converges long before 260k queries).
  // Estimated only when gaussian_sigma_resolutions > 0: building the kd-tree over every raw point costs
  // more than the queries.
  std::size_t resolution_samples = 20000;
};

// The keypoints features.voxel_size = auto (0) aims at in a cloud: what the indoor preset's 5 cm leaf
// leaves in a 3DMatch fragment (4 000-5 500), enough for FPFH to tell surfaces apart, few enough for the
// matching and the graph to stay in tens of milliseconds.
constexpr std::size_t kAutoVoxelKeypoints = 5000;

// The most the radii grow for features.min_feature_neighbours: FPFH's cost grows with the square of the
// points in its sphere, and a cloud that needs a wider support than this is scattered, not sparse.
constexpr double kMaxSupportScale = 4.0;

// The metric distances of the core that are derived from the voxel size when given as 0 (auto), in
// voxel sizes: the indoor preset's measured values at its 5 cm leaf (d_cmp 5 cm, tau 10 cm). A right
// match pairs two voxel centroids that each lie up to half a voxel diagonal (0.87 voxel) from the
// surface point they stand for, so an inlier threshold below ~2 voxels loses right matches.
constexpr double kGaussianSigmaVoxels = 1.0;       // graph.gaussian_sigma
constexpr double kQuadraticThresholdVoxels = 2.0;  // graph.quadratic_threshold
constexpr double kInlierThresholdVoxels = 2.0;     // evaluation.inlier_threshold

// Every problem with the parameters as a sentence naming parameter, value and allowed range; empty if usable.
// The ranges are the parameter table's entries (config/parameter_table.hpp), then the rules between them.
std::vector<std::string> validateFeatureParams(const FeatureParams& params);

}  // namespace mac_registration
