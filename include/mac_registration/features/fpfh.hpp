#pragma once

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// FPFH descriptors (Rusu et al. 2009) from the neighbours within `radius` [m]: PCL's SPFH and weighting
// steps on all `num_threads` threads (0 = one per core), the same descriptors as PCL's OpenMP estimator
// bit for bit, with each neighbourhood searched once instead of twice. `normals` must be finite.
FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads);

// Whether a descriptor can be matched: finite and not all zero (a point without neighbours).
bool isUsableDescriptor(const pcl::FPFHSignature33& descriptor);

}  // namespace mac_registration
