#include <pcl/features/normal_3d_omp.h>
#include <pcl/search/kdtree.h>

#include "mac_registration/features/normals.hpp"

namespace mac_registration {

NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, const PointCloud::ConstPtr& surface,
                                 double radius, int num_threads) {
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> estimator(num_threads > 0 ? num_threads : 0);
  estimator.setInputCloud(points);
  if (surface != points) estimator.setSearchSurface(surface);
  estimator.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimator.setRadiusSearch(radius);
  // FPFH angles depend on the sign of the normals: facing each cloud's own sensor makes the two clouds
  // agree on it for the surfaces both saw. The sensor origin is the frame's origin unless the cloud
  // says otherwise (a PCD's VIEWPOINT, a map assembled elsewhere).
  const Eigen::Vector4f& sensor = points->sensor_origin_;
  estimator.setViewPoint(sensor.x(), sensor.y(), sensor.z());
  auto normals = pcl::make_shared<NormalCloud>();
  estimator.compute(*normals);
  return normals;
}

NormalCloud::Ptr estimateNormals(const PointCloud::ConstPtr& points, double radius, int num_threads) {
  return estimateNormals(points, points, radius, num_threads);
}

}  // namespace mac_registration
