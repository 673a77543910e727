#pragma once

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// Normals from the points within `radius` [m], oriented towards the cloud's sensor_origin_ (the origin of
// its frame unless set); NaN where fewer than 3 neighbours fix a plane. The same normals, bit for bit, as
// PCL's NormalEstimationOMP with a kd-tree, on `num_threads` threads (0 = one per core). Throws Cancelled
// when `stop` is raised before it is done (each thread reads it every 4096 points).
NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, double radius, int num_threads,
                                 const StopFlag* stop = nullptr);

// The same at `points` from the neighbours on `surface` (PCL's setSearchSurface), oriented towards
// `points`' sensor_origin_: normals of a coarse grid fitted to the finer cloud it was made from.
NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, const PointCloud::ConstPtr& surface,
                                 double radius, int num_threads, const StopFlag* stop = nullptr);

}  // namespace mac_registration
