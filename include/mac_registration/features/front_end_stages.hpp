#pragma once

// The stages of the PCL front end, one source file each under src/features/, for callers that need one
// stage alone (and for their tests). computeCorrespondences() chains them.

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <vector>

#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {

using NormalCloud = pcl::PointCloud<pcl::Normal>;
using FpfhCloud = pcl::PointCloud<pcl::FPFHSignature33>;

// cloud_filtering.cpp: the points with three finite coordinates, as an unorganized cloud (an organized
// cloud's NaN pixels go too). `dropped` receives how many were removed.
PointCloud::Ptr finitePoints(const PointCloud& cloud, std::size_t& dropped);

// resolution.cpp: mean distance from a point to its nearest other point [m]. At most `max_queries`
// points, spread evenly over the cloud, are queried against the whole cloud. 0 for fewer than 2 points.
// `cloud` must be finite; throws std::invalid_argument when a coordinate is beyond kMaxAbsCoordinate (FLANN
// aborts the process on the overflowing distances of such points).
double meanNearestNeighbourDistance(const PointCloud::ConstPtr& cloud, std::size_t max_queries);

// voxel_downsampling.cpp: one point per occupied cubic voxel of edge `voxel_size` [m] (grid anchored at
// the origin), the centroid of its points; voxels in lexicographic order of their integer coordinates,
// so the result does not depend on the order of the input. Throws std::invalid_argument when the cloud
// spans more than 2^21 voxels along an axis, or a coordinate is not finite or lies more than 2^52 voxels
// from the origin (no finite input overflows the integer voxel indices).
PointCloud::Ptr voxelDownsample(const PointCloud& cloud, double voxel_size);

// normals.cpp: normals from the points within `radius` [m] (PCL's OpenMP estimator), oriented towards
// the cloud's sensor_origin_ (the origin of its frame unless set). NaN where fewer than 3 neighbours
// fix a plane.
NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, double radius, int num_threads);

// fpfh.cpp: FPFH descriptors (Rusu et al. 2009) from the neighbours within `radius` [m] (PCL's OpenMP
// estimator). `normals` must be finite.
FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads);

// fpfh.cpp: whether a descriptor can be matched: finite and not all zero (a point without neighbours).
bool isUsableDescriptor(const pcl::FPFHSignature33& descriptor);

// feature_matching.cpp: a putative correspondence between descriptor `source` of the source set and
// descriptor `target` of the target set, and their Euclidean distance in descriptor space.
struct FeatureMatch {
  int source = 0;
  int target = 0;
  float distance = 0.0f;
};

struct MatchingStats {
  std::size_t rejected_mutual = 0;  // source's nearest target has another nearest source
  std::size_t rejected_ratio = 0;   // nearest / second nearest distance above the ratio
  std::size_t truncated = 0;        // beyond max_correspondences
};

// feature_matching.cpp: each source descriptor's nearest target descriptor (exact kd-tree search),
// optionally kept only when mutual (params.mutual_filter) and distinctive (params.ratio_test); then the
// params.max_correspondences closest, ascending by distance (ties by source index: deterministic).
std::vector<FeatureMatch> matchFeatures(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats);

}  // namespace mac_registration
