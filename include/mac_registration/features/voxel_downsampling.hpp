#pragma once

#include "mac_registration/core/stop_flag.hpp"
#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

// One point per occupied cubic voxel of edge `voxel_size` [m] (grid anchored at
// the origin), the centroid of its points; voxels in lexicographic order of their integer coordinates,
// so the result does not depend on the order of the input, nor on `num_threads` (0 = one per core): a
// radix sort over the occupied box.
// Throws std::invalid_argument when the cloud spans more than 2^21 voxels along an axis, or a coordinate
// is not finite or lies more than 2^52 voxels from the origin (no finite input overflows the integer
// voxel indices). Throws Cancelled when `stop` is raised before it is done (read every 16k points).
PointCloud::Ptr voxelDownsample(const PointCloud& cloud, double voxel_size, int num_threads = 1,
                                const StopFlag* stop = nullptr);

}  // namespace mac_registration
