#pragma once

#include <string>

#include "mac_registration/core/parameters.hpp"
#include "synthetic.hpp"

namespace mac_registration::test {

inline std::string dataPath(const std::string& name) { return std::string(MAC_TEST_DATA_DIR) + "/" + name; }

inline const TriangleMesh& bunnyMesh() {
  static const TriangleMesh mesh = readAsciiPlyMesh(dataPath("teaser_bun_zipper_res3.ply"));
  return mesh;
}

// The synthetic scene of the tests and benchmarks: the bunny scaled to a 3 m room-sized object with 5 mm
// noise. Compatibility: pairs of inliers differ in length by ~2 sigma * sqrt(2) = 1.4 cm (std), so an edge
// up to d = 3.5 cm (Gaussian sigma 0.25 m at t_cmp 0.99 gives 0.1418 * 0.25) keeps nearly all of them.
inline SyntheticSpec roomScaleSpec(int n, double inlier_ratio, std::uint32_t seed) {
  SyntheticSpec spec;
  spec.correspondences = n;
  spec.inlier_ratio = inlier_ratio;
  spec.noise_sigma = 0.005;
  spec.object_size = 3.0;
  spec.seed = seed;
  return spec;
}

inline MacParams roomScaleParams() {
  MacParams params;
  params.graph.gaussian_sigma = 0.25;
  params.evaluation.inlier_threshold = 0.05;  // 10 sigma: every inlier, few outliers by chance
  return params;
}

}  // namespace mac_registration::test
