#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "mac_registration/core/correspondence_set.hpp"

namespace mac_registration {

// A triangle mesh, enough of one to sample points on its surface.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;
};

// Reads vertices (x y z first) and triangular faces from an ASCII PLY file. Throws std::runtime_error.
TriangleMesh readAsciiPlyMesh(const std::string& path);

struct SyntheticSpec {
  int correspondences = 1000;
  double inlier_ratio = 0.1;  // in [0, 1]
  double noise_sigma = 0.01;  // [m] Gaussian noise per axis on inlier targets
  double object_size = 1.0;   // [m] the mesh is scaled so that its bounding-box diagonal has this length
  std::uint32_t seed = 1;
};

struct SyntheticProblem {
  CorrespondenceSet correspondences;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  std::vector<char> is_inlier;
};

// Source points sampled uniformly on the mesh surface; inliers' targets are T s + noise, outliers' targets
// uniform in the bounding box of the transformed object. T is a random rotation (any angle) and a
// translation of up to object_size. Inliers and outliers are interleaved at random. Deterministic in seed.
SyntheticProblem makeSyntheticProblem(const TriangleMesh& mesh, const SyntheticSpec& spec);

}  // namespace mac_registration
