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

// Every point's neighbours within `radius` (itself included), nearest first: the same lists PCL's
// estimator searches for, once for the SPFH stage and again for the weighting stage.
struct Neighbourhoods {
  std::vector<pcl::Indices> indices;
  std::vector<std::vector<float>> squared_distances;
};

Neighbourhoods searchNeighbourhoods(const PointCloud::ConstPtr& points, double radius, int threads) {
  pcl::search::KdTree<pcl::PointXYZ> tree;  // sorted results, as the estimator's default search
  tree.setInputCloud(points);
  const int n = static_cast<int>(points->size());
  Neighbourhoods out;
  out.indices.resize(n);
  out.squared_distances.resize(n);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (int i = 0; i < n; ++i) tree.radiusSearch(i, radius, out.indices[i], out.squared_distances[i]);
  return out;
}

}  // namespace

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads) {
  const int threads = num_threads > 0 ? num_threads : omp_get_num_procs();
  const int n = static_cast<int>(points->size());
  const Neighbourhoods hood = searchNeighbourhoods(points, radius, threads);
  // PCL's own SPFH and weighting steps, on lists searched once: its OpenMP estimator searches every
  // neighbourhood twice, and that second search is a tenth of the descriptor time.
  // Both steps only read the estimator's constants, so one instance serves every thread (as in PCL's own
  // OpenMP estimator).
  Estimator estimator;
  Eigen::MatrixXf f1 = Eigen::MatrixXf::Zero(n, kBinsPerAngle), f2 = f1, f3 = f1;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (int i = 0; i < n; ++i) {
    if (hood.indices[i].empty()) continue;
    estimator.computePointSPFHSignature(*points, *normals, i, i, hood.indices[i], f1, f2, f3);
  }
  auto features = pcl::make_shared<FpfhCloud>();
  features->resize(n);
  features->header = points->header;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (int i = 0; i < n; ++i) {
    pcl::FPFHSignature33& out = (*features)[i];
    if (hood.indices[i].empty()) {
      std::fill(std::begin(out.histogram), std::end(out.histogram), std::numeric_limits<float>::quiet_NaN());
      continue;
    }
    Eigen::VectorXf histogram;
    estimator.weightPointSPFHSignature(f1, f2, f3, hood.indices[i], hood.squared_distances[i], histogram);
    for (int d = 0; d < 3 * kBinsPerAngle; ++d) out.histogram[d] = histogram[d];
  }
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
