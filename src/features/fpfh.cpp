#include <omp.h>
#include <pcl/features/fpfh.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <vector>

#include "mac_registration/features/fpfh.hpp"

namespace mac_registration {
namespace {

constexpr int kBinsPerAngle = 11;  // PCL's default: 3 x 11 = the 33 bins of FPFHSignature33
using Estimator = pcl::FPFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33>;
using Tree = pcl::search::KdTree<pcl::PointXYZ>;  // sorted results, as the estimator's default search

// Neighbours on the surface within `radius` (a surface point finds itself), nearest first: the lists
// PCL's estimator searches for, once for the SPFH stage and again for the weighting stage.
struct Neighbourhoods {
  std::vector<pcl::Indices> indices;
  std::vector<std::vector<float>> squared_distances;
};

Neighbourhoods searchNeighbourhoods(const Tree& surface, const PointCloud& queries, double radius,
                                    int threads) {
  const int n = static_cast<int>(queries.size());
  Neighbourhoods out;
  out.indices.resize(n);
  out.squared_distances.resize(n);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (int i = 0; i < n; ++i)
    surface.radiusSearch(queries[i], radius, out.indices[i], out.squared_distances[i]);
  return out;
}

// The surface points some keypoint's neighbourhood holds, ascending: only their SPFH is ever weighted.
std::vector<int> neededSurfacePoints(const Neighbourhoods& keypoint_hoods, std::size_t surface_size) {
  std::vector<char> needed(surface_size, 0);
  for (const auto& list : keypoint_hoods.indices) {
    for (const int s : list) needed[s] = 1;
  }
  std::vector<int> out;
  for (std::size_t s = 0; s < surface_size; ++s) {
    if (needed[s]) out.push_back(static_cast<int>(s));
  }
  return out;
}

// One SPFH row per surface point (zero where unneeded), so that the keypoints' lists index it directly.
struct SpfhRows {
  Eigen::MatrixXf f1, f2, f3;
};

// PCL's SPFH step at surface point `s`, from its own surface neighbourhood.
void spfhAt(Estimator& estimator, const PointCloud& surface, const NormalCloud& normals, int s,
            const pcl::Indices& neighbours, SpfhRows& rows) {
  if (neighbours.empty()) return;
  estimator.computePointSPFHSignature(surface, normals, s, s, neighbours, rows.f1, rows.f2, rows.f3);
}

// PCL's weighting step: keypoint `k`'s descriptor from the SPFH of its surface neighbours.
void weightAt(Estimator& estimator, const SpfhRows& rows, const Neighbourhoods& hoods, int k,
              pcl::FPFHSignature33& out) {
  if (hoods.indices[k].empty()) {
    std::fill(std::begin(out.histogram), std::end(out.histogram), std::numeric_limits<float>::quiet_NaN());
    return;
  }
  Eigen::VectorXf histogram;
  estimator.weightPointSPFHSignature(rows.f1, rows.f2, rows.f3, hoods.indices[k], hoods.squared_distances[k],
                                     histogram);
  for (int d = 0; d < 3 * kBinsPerAngle; ++d) out.histogram[d] = histogram[d];
}

int threadCount(int num_threads) { return num_threads > 0 ? num_threads : omp_get_num_procs(); }

}  // namespace

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& keypoints, const PointCloud::ConstPtr& surface,
                           const NormalCloud::ConstPtr& surface_normals, double radius, int num_threads) {
  const int threads = threadCount(num_threads);
  Tree tree;
  tree.setInputCloud(surface);
  // PCL's OpenMP estimator searches every neighbourhood twice; here each is searched once, and when the
  // keypoints are the surface their lists serve both steps.
  const Neighbourhoods keypoint_hoods = searchNeighbourhoods(tree, *keypoints, radius, threads);
  const bool same = keypoints == surface;
  const std::size_t m = surface->size();
  SpfhRows rows;
  rows.f1 = Eigen::MatrixXf::Zero(static_cast<Eigen::Index>(m), kBinsPerAngle);
  rows.f2 = rows.f1;
  rows.f3 = rows.f1;
  // PCL's two steps only read the estimator's constants: one instance serves every thread (as in PCL's own
  // OpenMP estimator).
  Estimator estimator;
  if (same) {
    const int n = static_cast<int>(m);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
    for (int s = 0; s < n; ++s)
      spfhAt(estimator, *surface, *surface_normals, s, keypoint_hoods.indices[s], rows);
  } else {
    // A surface coarser than the keypoints: the SPFH of each surface point a keypoint needs, from its
    // neighbours on the surface (PCL's FPFHEstimation with setSearchSurface does the same).
    const std::vector<int> needed = neededSurfacePoints(keypoint_hoods, m);
    const int count = static_cast<int>(needed.size());
#pragma omp parallel num_threads(threads)
    {
      pcl::Indices neighbours;
      std::vector<float> squared;
#pragma omp for schedule(dynamic, 64)
      for (int j = 0; j < count; ++j) {
        const int s = needed[j];
        tree.radiusSearch(s, radius, neighbours, squared);
        spfhAt(estimator, *surface, *surface_normals, s, neighbours, rows);
      }
    }
  }
  auto features = pcl::make_shared<FpfhCloud>();
  const int n = static_cast<int>(keypoints->size());
  features->resize(n);
  features->header = keypoints->header;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (int k = 0; k < n; ++k) weightAt(estimator, rows, keypoint_hoods, k, (*features)[k]);
  return features;
}

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads) {
  return computeFpfh(points, points, normals, radius, num_threads);
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
