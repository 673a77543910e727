// The front end's normals and FPFH against PCL's own estimators, bit for bit: on a shipped 3DMatch fragment
// and on hand-made surfaces that reach PCL's edge cases.
#include <gtest/gtest.h>
#include <pcl/features/fpfh.h>
#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/search/kdtree.h>

#include <cmath>
#include <limits>
#include <string>

#include "mac_registration/features/cloud_filtering.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/fpfh.hpp"
#include "mac_registration/features/normals.hpp"
#include "mac_registration/features/voxel_downsampling.hpp"

namespace mac_registration {
namespace {

// Redkitchen fragment 4, the demo's source cloud.
const PointCloud& fragment4() {
  static const PointCloud::Ptr cloud =
      loadCloud(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd");
  return *cloud;
}

// PCL's own normal estimator with a kd-tree: what estimateNormals must reproduce bit for bit.
NormalCloud pclNormals(const PointCloud::ConstPtr& points, const PointCloud::ConstPtr& surface,
                       double radius) {
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> estimator(2);
  estimator.setInputCloud(points);
  if (surface != points) estimator.setSearchSurface(surface);
  estimator.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimator.setRadiusSearch(radius);
  const Eigen::Vector4f& sensor = points->sensor_origin_;
  estimator.setViewPoint(sensor.x(), sensor.y(), sensor.z());
  NormalCloud normals;
  estimator.compute(normals);
  return normals;
}

// PCL's value: equal, or NaN where PCL's is NaN.
bool sameAsPcl(float actual, float expected) {
  return actual == expected || (std::isnan(actual) && std::isnan(expected));
}

// Descriptor bins that are not PCL's.
std::size_t differingBins(const FpfhCloud& actual, const FpfhCloud& expected) {
  std::size_t differing = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    for (int d = 0; d < 33; ++d) differing += !sameAsPcl(actual[i].histogram[d], expected[i].histogram[d]);
  }
  return differing;
}

std::size_t differingNormals(const NormalCloud& actual, const NormalCloud& expected) {
  std::size_t differing = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const pcl::Normal &a = actual[i], &e = expected[i];
    differing += !(sameAsPcl(a.normal_x, e.normal_x) && sameAsPcl(a.normal_y, e.normal_y) &&
                   sameAsPcl(a.normal_z, e.normal_z) && sameAsPcl(a.curvature, e.curvature));
  }
  return differing;
}

// On the voxels themselves and, as describeCloud's coarser support surface, on a grid fitted to them;
// the radius leaves some voxels too few neighbours, so NaN normals are compared too.
TEST(RealPair, NormalsArePclsOwnEstimatorsBitForBit) {
  std::size_t dropped = 0;
  PointCloud::Ptr voxels = voxelDownsample(*finitePoints(fragment4(), dropped), 0.05);
  voxels->sensor_origin_ = Eigen::Vector4f(0.3f, -0.2f, 0.1f, 0.0f);
  PointCloud::Ptr grid = voxelDownsample(*voxels, 0.1);
  grid->sensor_origin_ = voxels->sensor_origin_;
  for (const double radius : {0.06, 0.1}) {
    const NormalCloud on_voxels = pclNormals(voxels, voxels, radius);
    const NormalCloud on_grid = pclNormals(grid, voxels, radius);
    std::size_t nan = 0;
    for (const auto& n : on_voxels) nan += std::isnan(n.normal_x);
    if (radius < 0.1) {
      EXPECT_GT(nan, 0u) << "no voxel without a normal at radius " << radius;
    }
    for (const int threads : {1, 2}) {
      const NormalCloud::Ptr actual = estimateNormals(voxels, radius, threads);
      ASSERT_EQ(actual->size(), on_voxels.size());
      EXPECT_EQ(differingNormals(*actual, on_voxels), 0u) << radius << " m, " << threads << " threads";
      const NormalCloud::Ptr fitted = estimateNormals(grid, voxels, radius, threads);
      ASSERT_EQ(fitted->size(), on_grid.size());
      EXPECT_EQ(differingNormals(*fitted, on_grid), 0u)
          << radius << " m on the grid, " << threads << " threads";
    }
  }
}

// The descriptors of PCL's OpenMP estimator, which searches every neighbourhood twice: what
// computeFpfh must reproduce bit for bit.
FpfhCloud pclFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals, double radius) {
  pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> estimator(2);
  estimator.setInputCloud(points);
  estimator.setInputNormals(normals);
  estimator.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimator.setRadiusSearch(radius);
  FpfhCloud features;
  estimator.compute(features);
  return features;
}

TEST(RealPair, FpfhIsPclsOwnEstimatorsBitForBit) {
  std::size_t dropped = 0;
  const PointCloud::Ptr voxels = voxelDownsample(*finitePoints(fragment4(), dropped), 0.05);
  const NormalCloud::Ptr all_normals = estimateNormals(voxels, 0.1, 0);
  // As describeCloud does: only points with a normal take part.
  auto points = pcl::make_shared<PointCloud>();
  auto normals = pcl::make_shared<NormalCloud>();
  for (std::size_t i = 0; i < voxels->size(); ++i) {
    if (!std::isfinite((*all_normals)[i].normal_x)) continue;
    points->push_back((*voxels)[i]);
    normals->push_back((*all_normals)[i]);
  }
  ASSERT_GT(points->size(), 1000u);
  const double radius = 0.25;
  const FpfhCloud expected = pclFpfh(points, normals, radius);
  for (const int threads : {1, 2}) {
    const FpfhCloud::Ptr actual = computeFpfh(points, normals, radius, threads);
    ASSERT_EQ(actual->size(), expected.size());
    EXPECT_EQ(differingBins(*actual, expected), 0u) << threads << " threads";
  }
}

// Where two points share a normal both see the line between them at the same angle, to the float: PCL's
// pair feature then keeps the order it is given, and (p, q) and (q, p) differ in the sign of f3, so one
// feature computed for both points would not be PCL's. A plane whose normals all lean the same way
// makes every pair such a pair.
TEST(Fpfh, PairsSeenAtTheSameAngleFromBothEndsArePclsBitForBit) {
  auto points = pcl::make_shared<PointCloud>();
  auto normals = pcl::make_shared<NormalCloud>();
  pcl::Normal leaning;
  leaning.getNormalVector3fMap() = Eigen::Vector3f(0.6f, 0.2f, 1.0f).normalized();
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 30; ++j) {
      points->push_back(pcl::PointXYZ(float(i) * 0.02f, float(j) * 0.02f, 1.0f));
      normals->push_back(leaning);
    }
  }
  const double radius = 0.1;
  const FpfhCloud expected = pclFpfh(points, normals, radius);
  for (const int threads : {1, 2}) {
    const FpfhCloud::Ptr actual = computeFpfh(points, normals, radius, threads);
    ASSERT_EQ(actual->size(), expected.size());
    EXPECT_EQ(differingBins(*actual, expected), 0u) << threads << " threads";
  }
}

// PCL weights a neighbour by 1 / d²: a point 10 µm from another weighs 10^10 (its weighted bins and
// those of the far neighbours span more bits than PCL's double sums hold), and one 10^-20 m away weighs
// infinity (NaN even in the bins its SPFH leaves empty). Both must come out as PCL's, and a point that
// is not finite too.
TEST(Fpfh, NearlyCoincidentPointsArePclsBitForBit) {
  auto points = pcl::make_shared<PointCloud>();
  auto normals = pcl::make_shared<NormalCloud>();
  const auto add = [&](float x, float y) {
    points->push_back(pcl::PointXYZ(x, y, 0.3f * x * x));
    pcl::Normal normal;
    normal.getNormalVector3fMap() = Eigen::Vector3f(-0.6f * x, 0.1f * y, 1.0f).normalized();
    normals->push_back(normal);
  };
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) add(float(i) * 0.02f, float(j) * 0.02f);
  }
  add(0.2f + 1e-5f, 0.2f);
  add(1e-20f, 0.0f);
  add(std::numeric_limits<float>::quiet_NaN(), 0.1f);  // left out of every neighbourhood, as by PCL
  const double radius = 0.1;
  const FpfhCloud expected = pclFpfh(points, normals, radius);
  for (const int threads : {1, 2}) {
    const FpfhCloud::Ptr actual = computeFpfh(points, normals, radius, threads);
    ASSERT_EQ(actual->size(), expected.size());
    std::size_t nan = 0;
    for (const auto& descriptor : expected) {
      for (const float bin : descriptor.histogram) nan += std::isnan(bin);
    }
    EXPECT_EQ(differingBins(*actual, expected), 0u) << threads << " threads";
    EXPECT_GT(nan, 0u) << "the infinite weight did not reach PCL's descriptors";
  }
}

// PCL's own estimator with a separate search surface: the descriptors computeFpfh must reproduce bit for
// bit when the surface is coarser than the keypoints.
FpfhCloud pclFpfhOnSurface(const PointCloud::ConstPtr& keypoints, const PointCloud::ConstPtr& surface,
                           const NormalCloud::ConstPtr& surface_normals, double radius) {
  pcl::FPFHEstimation<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> estimator;
  estimator.setInputCloud(keypoints);
  estimator.setSearchSurface(surface);
  estimator.setInputNormals(surface_normals);
  estimator.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimator.setRadiusSearch(radius);
  FpfhCloud features;
  estimator.compute(features);
  return features;
}

TEST(RealPair, FpfhOnACoarserSupportSurfaceIsPclsSearchSurfaceEstimatorBitForBit) {
  std::size_t dropped = 0;
  const PointCloud::Ptr keypoints = voxelDownsample(*finitePoints(fragment4(), dropped), 0.05);
  // As describeCloud does with support_voxel_factor 2: a grid of the keypoints, its normals fitted to
  // the keypoints, only surface points with a normal.
  const PointCloud::Ptr grid = voxelDownsample(*keypoints, 0.1);
  const NormalCloud::Ptr grid_normals = estimateNormals(grid, keypoints, 0.1, 0);
  auto surface = pcl::make_shared<PointCloud>();
  auto normals = pcl::make_shared<NormalCloud>();
  for (std::size_t i = 0; i < grid->size(); ++i) {
    if (!std::isfinite((*grid_normals)[i].normal_x)) continue;
    surface->push_back((*grid)[i]);
    normals->push_back((*grid_normals)[i]);
  }
  ASSERT_GT(surface->size(), 300u);
  ASSERT_LT(surface->size(), keypoints->size() / 2);
  const double radius = 0.25;
  const FpfhCloud expected = pclFpfhOnSurface(keypoints, surface, normals, radius);
  for (const int threads : {1, 2}) {
    const FpfhCloud::Ptr actual = computeFpfh(keypoints, surface, normals, radius, threads);
    ASSERT_EQ(actual->size(), expected.size());
    std::size_t usable = 0;
    for (const auto& descriptor : *actual) usable += isUsableDescriptor(descriptor);
    EXPECT_EQ(differingBins(*actual, expected), 0u) << threads << " threads";
    EXPECT_GT(usable, expected.size() * 9 / 10) << threads << " threads";
  }
}

}  // namespace
}  // namespace mac_registration
