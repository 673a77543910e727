// The front end's stages alone, on hand-made clouds and descriptors whose answers are known exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>

#include "mac_registration/features/cloud_filtering.hpp"
#include "mac_registration/features/feature_matching.hpp"
#include "mac_registration/features/fpfh.hpp"
#include "mac_registration/features/normals.hpp"
#include "mac_registration/features/resolution.hpp"
#include "mac_registration/features/voxel_downsampling.hpp"

namespace mac_registration {
namespace {

PointCloud cloudOf(std::initializer_list<pcl::PointXYZ> points) {
  PointCloud cloud;
  for (const auto& p : points) cloud.push_back(p);
  return cloud;
}

// A planar grid of n x n points with the given spacing [m], at height z.
PointCloud::Ptr grid(int n, float spacing, float z = 0.0f) {
  auto cloud = pcl::make_shared<PointCloud>();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) cloud->push_back(pcl::PointXYZ(i * spacing, j * spacing, z));
  return cloud;
}

TEST(FinitePoints, DropsAndCountsNonFiniteAndUnorganizes) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  PointCloud organized =
      cloudOf({{0, 0, 1}, {nan, nan, nan}, {1, 0, 1}, {0, inf, 1}, {0, 1, 1}, {1, 1, nan}});
  organized.width = 3;
  organized.height = 2;
  organized.is_dense = false;
  std::size_t dropped = 0;
  const PointCloud::Ptr finite = finitePoints(organized, dropped);
  EXPECT_EQ(dropped, 3u);
  ASSERT_EQ(finite->size(), 3u);
  EXPECT_EQ(finite->height, 1u);  // no longer an image: rows would not line up
  EXPECT_EQ(finite->width, 3u);
  EXPECT_TRUE(finite->is_dense);
  EXPECT_FLOAT_EQ((*finite)[1].x, 1.0f);  // order kept
}

TEST(VoxelDownsample, AveragesThePointsOfEachVoxel) {
  // Two points share voxel (0,0,0) of a 1 m grid, one sits alone in voxel (-1,0,0): floor, not truncation.
  const PointCloud cloud = cloudOf({{0.2f, 0.2f, 0.2f}, {0.4f, 0.6f, 0.8f}, {-0.5f, 0.5f, 0.5f}});
  const PointCloud::Ptr voxels = voxelDownsample(cloud, 1.0);
  ASSERT_EQ(voxels->size(), 2u);
  // Lexicographic voxel order: x = -1 first.
  EXPECT_FLOAT_EQ((*voxels)[0].x, -0.5f);
  EXPECT_NEAR((*voxels)[1].x, 0.3f, 1e-6);
  EXPECT_NEAR((*voxels)[1].y, 0.4f, 1e-6);
  EXPECT_NEAR((*voxels)[1].z, 0.5f, 1e-6);
}

TEST(VoxelDownsample, DoesNotDependOnTheOrderOfThePoints) {
  PointCloud::Ptr cloud = grid(40, 0.013f);
  const PointCloud::Ptr forward = voxelDownsample(*cloud, 0.05);
  std::mt19937 rng(3);
  std::shuffle(cloud->points.begin(), cloud->points.end(), rng);
  const PointCloud::Ptr shuffled = voxelDownsample(*cloud, 0.05);
  ASSERT_EQ(forward->size(), shuffled->size());
  for (std::size_t i = 0; i < forward->size(); ++i) {
    // Same voxels, same order; centroids equal up to float summation order.
    EXPECT_NEAR((*forward)[i].x, (*shuffled)[i].x, 1e-6);
    EXPECT_NEAR((*forward)[i].y, (*shuffled)[i].y, 1e-6);
  }
  // 40 points at 1.3 cm span 0.507 m: 11 voxels of 5 cm per axis.
  EXPECT_EQ(forward->size(), 11u * 11u);
}

// A box of 10 m at 5 cm holds 8 M possible voxels: the keys need several passes of the radix sort, whose
// order must still be the lexicographic order of the voxels, each centroid the mean of its points, on one
// thread or two.
TEST(VoxelDownsample, OrdersAWideCloudLexicographically) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(-5.0f, 5.0f);
  PointCloud cloud;
  for (int i = 0; i < 20000; ++i)
    cloud.push_back(pcl::PointXYZ(coordinate(rng), coordinate(rng), coordinate(rng)));
  const double voxel = 0.05, inverse = 1.0 / voxel;  // the grid's own arithmetic, for the boundaries
  const auto cellOf = [&](const pcl::PointXYZ& p) {
    return std::array<long, 3>{long(std::floor(p.x * inverse)), long(std::floor(p.y * inverse)),
                               long(std::floor(p.z * inverse))};
  };
  std::map<std::array<long, 3>, std::array<double, 4>> expected;  // sums and count per voxel
  for (const auto& p : cloud) {
    auto& sum = expected[cellOf(p)];
    sum[0] += p.x, sum[1] += p.y, sum[2] += p.z, sum[3] += 1.0;
  }
  const PointCloud::Ptr one = voxelDownsample(cloud, voxel);
  ASSERT_EQ(one->size(), expected.size());
  std::size_t i = 0;
  for (const auto& [cell, sum] : expected) {
    const pcl::PointXYZ& p = (*one)[i++];
    EXPECT_EQ(cellOf(p), cell) << i;
    EXPECT_FLOAT_EQ(p.x, float(sum[0] / sum[3])) << i;
    EXPECT_FLOAT_EQ(p.z, float(sum[2] / sum[3])) << i;
  }
  // The threads split the passes over the points and the voxels, never the sums of one voxel.
  const PointCloud::Ptr two = voxelDownsample(cloud, voxel, 2);
  ASSERT_EQ(two->size(), one->size());
  std::size_t differing = 0;
  for (std::size_t v = 0; v < one->size(); ++v) {
    differing += (*one)[v].x != (*two)[v].x || (*one)[v].y != (*two)[v].y || (*one)[v].z != (*two)[v].z;
  }
  EXPECT_EQ(differing, 0u);
}

TEST(VoxelDownsample, RefusesAGridTooFineForTheExtent) {
  const PointCloud cloud = cloudOf({{0, 0, 0}, {3000.0f, 0, 0}});
  EXPECT_THROW(voxelDownsample(cloud, 0.001), std::invalid_argument);  // 3 M voxels along x
  EXPECT_EQ(voxelDownsample(cloud, 0.01)->size(), 2u);                 // 300 k: fine
}

// Voxel indices are computed in double and range-checked before the cast: coordinates of 1e20 m (UBSan
// reported a signed overflow here) or float's largest are refused, never wrapped into a wrong voxel.
TEST(VoxelDownsample, RefusesCoordinatesWhoseVoxelIndexWouldOverflow) {
  const float largest = std::numeric_limits<float>::max();
  for (const float far : {1e20f, -1e20f, 3e38f, largest, -largest}) {
    const PointCloud cloud = cloudOf({{0, 0, 0}, {0, far, 0}});
    try {
      voxelDownsample(cloud, 0.05);
      ADD_FAILURE() << "no error for y = " << far;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("2^52 voxels"), std::string::npos) << e.what();
    }
  }
  // A tiny voxel makes the index overflow a double too (Inf): refused the same way.
  EXPECT_THROW(voxelDownsample(cloudOf({{1e10f, 0, 0}}), 1e-300), std::invalid_argument);
  // Within 2^52 voxels but spread over more than 2^21: the extent check answers.
  try {
    voxelDownsample(cloudOf({{-1e9f, 0, 0}, {1e9f, 0, 0}}), 1.0);
    ADD_FAILURE() << "no error for a 2e9-voxel extent";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("raise the voxel size"), std::string::npos) << e.what();
  }
  // Far from the origin but compact: fine.
  EXPECT_EQ(voxelDownsample(cloudOf({{9e5f, 0, 0}, {9e5f, 1, 0}}), 0.5)->size(), 2u);
}

TEST(CoordinateBound, AllowsTheBoundAndRefusesBeyondItNamingThePoint) {
  const float bound = float(kMaxAbsCoordinate);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(coordinateBoundProblem(cloudOf({{bound, -bound, 0}, {nan, inf, 1}})), "");
  const std::string problem = coordinateBoundProblem(cloudOf({{0, 0, 0}, {1, 2, 3}, {0, 0, -1.5e6f}}));
  EXPECT_NE(problem.find("point 2 has z = -1.5e+06 m"), std::string::npos) << problem;
  EXPECT_NE(problem.find("+-1e+06 m"), std::string::npos) << problem;
  EXPECT_NE(problem.find("float32"), std::string::npos) << problem;  // why there is a bound
  EXPECT_NE(coordinateBoundProblem(pcl::PointXYZ(3e38f, 0, 0), 41).find("point 41 has x = 3e+38"),
            std::string::npos);
}

// FLANN aborts the whole process (an assertion in its heap) on the overflowing distances of such points.
TEST(Resolution, RefusesCoordinatesBeyondTheBoundInsteadOfBuildingAKdTree) {
  PointCloud::Ptr cloud = grid(5, 0.1f);
  cloud->push_back(pcl::PointXYZ(3e38f, 3e38f, 3e38f));
  try {
    meanNearestNeighbourDistance(cloud, 100);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("point 25 has x = 3e+38"), std::string::npos) << e.what();
  }
}

TEST(Resolution, IsTheSpacingOfARegularGrid) {
  EXPECT_NEAR(meanNearestNeighbourDistance(grid(50, 0.02f), 100000), 0.02, 1e-6);
  // A subsample of the queries still searches the whole cloud: the same answer.
  EXPECT_NEAR(meanNearestNeighbourDistance(grid(50, 0.02f), 100), 0.02, 1e-6);
  EXPECT_EQ(meanNearestNeighbourDistance(grid(1, 0.02f), 100), 0.0);
}

TEST(Normals, OfAPlaneFaceTheSensor) {
  const PointCloud::Ptr plane = grid(20, 0.05f, 2.0f);  // z = 2 m, seen from below
  const NormalCloud::Ptr normals = estimateNormals(plane, 0.12, 2);
  ASSERT_EQ(normals->size(), plane->size());
  for (const auto& n : normals->points) EXPECT_NEAR(n.normal_z, -1.0f, 1e-4);
  // A sensor above the plane (e.g. a PCD's VIEWPOINT) turns them around.
  plane->sensor_origin_ = Eigen::Vector4f(0.5f, 0.5f, 5.0f, 0.0f);
  const NormalCloud::Ptr flipped = estimateNormals(plane, 0.12, 2);
  for (const auto& n : flipped->points) EXPECT_NEAR(n.normal_z, 1.0f, 1e-4);
}

pcl::FPFHSignature33 descriptor(std::initializer_list<float> leading) {
  pcl::FPFHSignature33 d;
  std::fill(std::begin(d.histogram), std::end(d.histogram), 0.0f);
  std::copy(leading.begin(), leading.end(), d.histogram);
  return d;
}

FpfhCloud::Ptr descriptors(std::initializer_list<pcl::FPFHSignature33> list) {
  auto cloud = pcl::make_shared<FpfhCloud>();
  for (const auto& d : list) cloud->push_back(d);
  return cloud;
}

TEST(Fpfh, UnusableDescriptorsAreRecognized) {
  EXPECT_TRUE(isUsableDescriptor(descriptor({1.0f})));
  EXPECT_FALSE(isUsableDescriptor(descriptor({})));  // all zero: a point without neighbours
  EXPECT_FALSE(isUsableDescriptor(descriptor({std::numeric_limits<float>::quiet_NaN(), 1.0f})));
}

// Source descriptors 0..2 and target descriptors 0..2 in one dimension, at known distances:
//   s0 = 0    -> t0 = 0.1 (d 0.1), runner-up t1 = 1.0 (d 1.0): distinctive, mutual
//   s1 = 1.5  -> t1 = 1.0 (d 0.5), runner-up t2 = 2.0 (d 0.5): ambiguous (ratio 1)
//   s2 = 0.05 -> t0 = 0.1 (d 0.05): t0's nearest source is s2, so s0 -> t0 is not mutual
class MatchFeatures : public ::testing::Test {
 protected:
  FpfhCloud::Ptr source = descriptors({descriptor({0.0f, 1}), descriptor({1.5f, 1}), descriptor({0.05f, 1})});
  FpfhCloud::Ptr target = descriptors({descriptor({0.1f, 1}), descriptor({1.0f, 1}), descriptor({2.0f, 1})});
  FeatureParams params;
  MatchingStats stats;
};

TEST_F(MatchFeatures, NearestNeighboursSortedByDistance) {
  const auto matches = matchFeatures(source, target, params, stats);
  ASSERT_EQ(matches.size(), 3u);
  EXPECT_EQ(matches[0].source, 2);  // d 0.05
  EXPECT_EQ(matches[0].target, 0);
  EXPECT_NEAR(matches[0].distance, 0.05f, 1e-6);
  EXPECT_EQ(matches[1].source, 0);  // d 0.1
  EXPECT_EQ(matches[2].source, 1);  // d 0.5
}

TEST_F(MatchFeatures, MutualCheckDropsOneSidedMatches) {
  params.mutual_filter = true;
  const auto matches = matchFeatures(source, target, params, stats);
  // s0 -> t0 is not mutual (t0 prefers s2); s1 -> t1 or t2 at equal distance: t1's nearest source is s1?
  // |1.0 - 1.5| = 0.5 vs |1.0 - 0.05| = 0.95 and |1.0 - 0| = 1: yes, whichever of t1/t2 was picked,
  // both have s1 as their nearest source.
  EXPECT_EQ(stats.rejected_mutual, 1u);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].source, 2);
  EXPECT_EQ(matches[1].source, 1);
}

TEST_F(MatchFeatures, RatioTestDropsAmbiguousMatches) {
  params.ratio_test = 0.8;
  const auto matches = matchFeatures(source, target, params, stats);
  EXPECT_EQ(stats.rejected_ratio, 1u);  // s1: 0.5 / 0.5
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].source, 2);
  EXPECT_EQ(matches[1].source, 0);
}

TEST_F(MatchFeatures, KeepsTheClosestMaxCorrespondences) {
  params.max_correspondences = 2;
  const auto matches = matchFeatures(source, target, params, stats);
  EXPECT_EQ(stats.truncated, 1u);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[1].source, 0);
}

}  // namespace
}  // namespace mac_registration
