#pragma once

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// FPFH descriptors (Rusu et al. 2009) at `keypoints` from the points of `surface` within `radius` [m,
// > 0, else std::invalid_argument]: PCL's SPFH step at every surface point some keypoint's neighbourhood
// holds (from its own surface neighbours and `surface_normals`, which must be finite), then PCL's
// weighting of those SPFH at each keypoint. The same descriptors as PCL's FPFHEstimation with
// setSearchSurface(surface) bit for bit, on all `num_threads` threads (0 = one per core): PCL's pair
// feature function and PCL's float arithmetic in loops that search each neighbourhood once (a grid
// giving the kd-tree's lists), compute a pair feature once for both of its points where PCL's function
// gives both the same, and store the SPFH row by row.
// A surface coarser than the keypoints makes each descriptor a sum over fewer pair features; the
// keypoints' own normals are not used. NaN where a keypoint has no surface point within `radius`. Throws
// Cancelled when `stop` is raised before it is done (each thread reads it every 4096 points of a pass).
FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& keypoints, const PointCloud::ConstPtr& surface,
                           const NormalCloud::ConstPtr& surface_normals, double radius, int num_threads,
                           const StopFlag* stop = nullptr);

// The keypoints as their own surface: PCL's OpenMP estimator's descriptors bit for bit.
FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads, const StopFlag* stop = nullptr);

// Whether a descriptor can be matched: finite and not all zero (a point without neighbours).
bool isUsableDescriptor(const pcl::FPFHSignature33& descriptor);

}  // namespace mac_registration
