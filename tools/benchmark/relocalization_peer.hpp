#pragma once

// The peer of the relocalization benchmark: FPFH + RANSAC against the whole map, as hdl_global_localization's
// engine searches it: PCL's prerejective RANSAC (3-point samples among each query feature's 2 nearest map
// features, polygon-similarity screening, a pose kept when a quarter of the query lands within tau of the
// map), on the same keypoints and descriptors as ours.

#include <Eigen/Geometry>
#include <memory>

#include "mac_registration/features/map_relocalization.hpp"

namespace mac_registration {

class RansacPeer {
 public:
  // Prepares `map` (kept by reference): its descriptors' search tree. `tau` [m]: the inlier distance.
  RansacPeer(const DescribedMap& map, int iterations, double tau);
  ~RansacPeer();

  struct Answer {
    bool converged = false;
    Eigen::Isometry3d T_map_query = Eigen::Isometry3d::Identity();
    double ms = 0.0;  // describing the query and the search
  };
  Answer localize(const PointCloud& query, const FeatureParams& features);

  double setup_ms = 0.0;

 private:
  struct Search;
  const DescribedMap& map_;
  std::unique_ptr<Search> search_;
};

}  // namespace mac_registration
