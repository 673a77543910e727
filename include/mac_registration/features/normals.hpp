#pragma once

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Normals from the points within `radius` [m] (PCL's OpenMP estimator), oriented towards
// the cloud's sensor_origin_ (the origin of its frame unless set). NaN where fewer than 3 neighbours
// fix a plane.
NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, double radius, int num_threads);

}  // namespace mac_registration
