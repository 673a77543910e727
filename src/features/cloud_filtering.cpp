#include <cmath>

#include "mac_registration/features/front_end_stages.hpp"

namespace mac_registration {

PointCloud::Ptr finitePoints(const PointCloud& cloud, std::size_t& dropped) {
  auto finite = pcl::make_shared<PointCloud>();
  finite->reserve(cloud.size());
  for (const auto& p : cloud.points) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) finite->push_back(p);
  }
  // push_back keeps width = size and height = 1: the result is unorganized even if the input was not.
  finite->header = cloud.header;
  finite->sensor_origin_ = cloud.sensor_origin_;
  finite->sensor_orientation_ = cloud.sensor_orientation_;
  finite->is_dense = true;
  dropped = cloud.size() - finite->size();
  return finite;
}

}  // namespace mac_registration
