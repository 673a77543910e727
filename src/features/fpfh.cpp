#include <pcl/features/fpfh_omp.h>
#include <pcl/search/kdtree.h>

#include <cmath>

#include "mac_registration/features/fpfh.hpp"

namespace mac_registration {

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads) {
  pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> estimator(
      num_threads > 0 ? num_threads : 0);
  estimator.setInputCloud(points);
  estimator.setInputNormals(normals);
  estimator.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimator.setRadiusSearch(radius);
  auto features = pcl::make_shared<FpfhCloud>();
  estimator.compute(*features);
  return features;
}

bool isUsableDescriptor(const pcl::FPFHSignature33& descriptor) {
  float sum = 0.0f;
  for (const float bin : descriptor.histogram) {
    if (!std::isfinite(bin)) return false;
    sum += bin;
  }
  return sum > 0.0f;
}

}  // namespace mac_registration
