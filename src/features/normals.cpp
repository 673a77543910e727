#include <omp.h>
#include <pcl/features/normal_3d.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "mac_registration/features/normals.hpp"
#include "radius_search.hpp"

namespace mac_registration {

NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, const PointCloud::ConstPtr& surface,
                                 double radius, int num_threads, const StopFlag* stop) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("normal radius must be a finite length > 0 m, got " + std::to_string(radius));
  // PCL's NormalEstimationOMP, point for point: the same neighbour lists in the same order (the grid
  // instead of a kd-tree, whose build and queries cost more than the fits), PCL's own plane fit and
  // orientation on them.
  const CloudGrid grid = cloudGrid(*surface, radius);
  auto normals = pcl::make_shared<NormalCloud>();
  const int n = static_cast<int>(points->size());
  normals->resize(n);
  normals->header = points->header;
  if (points->width * points->height == points->size())
    normals->width = points->width, normals->height = points->height;
  // FPFH angles depend on the sign of the normals: facing each cloud's own sensor makes the two clouds
  // agree on it for the surfaces both saw. The sensor origin is the frame's origin unless the cloud
  // says otherwise (a PCD's VIEWPOINT, a map assembled elsewhere).
  const Eigen::Vector4f& sensor = points->sensor_origin_;
  bool dense = true;
  const int threads = num_threads > 0 ? num_threads : omp_get_num_procs();
#pragma omp parallel num_threads(threads) reduction(&& : dense)
  {
    Neighbourhood hood;
    std::vector<std::uint64_t> keys, scratch;
    StopCheck check(stop);
#pragma omp for schedule(dynamic, 256)
    for (int i = 0; i < n; ++i) {
      if (check.stopped()) continue;
      pcl::Normal& out = (*normals)[i];
      radiusSearch(grid, (*points)[i], true, hood, keys, scratch);
      Eigen::Vector4f plane;
      if (hood.indices.empty() || !pcl::computePointNormal(*surface, hood.indices, plane, out.curvature)) {
        out.normal_x = out.normal_y = out.normal_z = out.curvature = std::numeric_limits<float>::quiet_NaN();
        dense = false;
        continue;
      }
      out.normal_x = plane[0], out.normal_y = plane[1], out.normal_z = plane[2];
      pcl::flipNormalTowardsViewpoint((*points)[i], sensor.x(), sensor.y(), sensor.z(), out.normal_x,
                                      out.normal_y, out.normal_z);
    }
  }
  throwIfStopped(stop, "estimating normals");
  normals->is_dense = dense;
  return normals;
}

NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, double radius, int num_threads,
                                 const StopFlag* stop) {
  return estimateNormals(points, points, radius, num_threads, stop);
}

}  // namespace mac_registration
