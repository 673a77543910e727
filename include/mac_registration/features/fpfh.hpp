#pragma once

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// FPFH descriptors (Rusu et al. 2009) from the neighbours within `radius` [m] (PCL's OpenMP
// estimator). `normals` must be finite.
FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads);

// Whether a descriptor can be matched: finite and not all zero (a point without neighbours).
bool isUsableDescriptor(const pcl::FPFHSignature33& descriptor);

}  // namespace mac_registration
