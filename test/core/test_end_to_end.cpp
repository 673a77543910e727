// End-to-end registration on synthetic bunny sets and on a real 3DMatch FPFH correspondence set.
#include <gtest/gtest.h>

#include <random>
#include <tuple>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "test_support.hpp"

namespace mac_registration {
namespace {

using test::dataPath;

class SyntheticRegistration : public ::testing::TestWithParam<std::tuple<int, double>> {};

TEST_P(SyntheticRegistration, RecoversKnownTransform) {
  const auto [n, ratio] = GetParam();
  const SyntheticProblem problem = makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(n, ratio, 7));
  const MacResult result = registerCorrespondences(problem.correspondences, test::roomScaleParams());
  ASSERT_TRUE(result.success) << toString(result.status) << ": " << result.message;
  // 2 deg is the bound; with >= 12 inliers at 5 mm noise on a 3 m object the SVD error is far
  // below it. 5 cm translation = 10 noise sigmas, the evaluation threshold.
  EXPECT_LT(rotationErrorDeg(result.T_target_source, problem.T_target_source), 2.0);
  EXPECT_LT(translationError(result.T_target_source, problem.T_target_source), 0.05);
  // Most reported inliers must be true inliers (outliers land inside 5 cm only by chance).
  std::size_t true_inliers = 0;
  for (int i : result.inlier_indices) true_inliers += problem.is_inlier[i];
  EXPECT_GE(true_inliers * 10, result.inlier_indices.size() * 9);
}

INSTANTIATE_TEST_SUITE_P(InlierRatiosAndSizes, SyntheticRegistration,
                         ::testing::Combine(::testing::Values(250, 1000, 5000),
                                            ::testing::Values(0.05, 0.10, 0.50)));

TEST(SyntheticRegistration, SameResultWhateverTheThreadCount) {
  const SyntheticProblem problem =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(2000, 0.1, 11));
  MacParams params = test::roomScaleParams();
  params.num_threads = 1;
  const MacResult one = registerCorrespondences(problem.correspondences, params);
  params.num_threads = 2;
  const MacResult two = registerCorrespondences(problem.correspondences, params);
  ASSERT_TRUE(one.success);
  EXPECT_TRUE(one.T_target_source.matrix() == two.T_target_source.matrix());  // bitwise, not approximately
  EXPECT_EQ(one.inlier_indices, two.inlier_indices);
  EXPECT_EQ(one.counters.cliques, two.counters.cliques);
  EXPECT_EQ(one.counters.selected_cliques, two.counters.selected_cliques);
}

// Two consensuses on one source: 40 matches at an upright pose (a turn about z) and 60 at that pose
// tipped 120 deg about x, among 300 unrelated matches. The larger one wins with no prior; with
// evaluation.max_tilt_deg 45 its hypotheses are not taken and the upright pose is found.
TEST(TiltPrior, TakesTheUprightConsensusOverALargerTippedOne) {
  const SyntheticProblem scene = makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(480, 0.0, 5));
  Eigen::Isometry3d upright = Eigen::Isometry3d::Identity();
  upright.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  upright.translation() = Eigen::Vector3d(1.0, 0.5, 0.0);
  const Eigen::Isometry3d tipped = upright * Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitX());
  CorrespondenceSet c = scene.correspondences;  // its targets are unrelated to the sources
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.005);
  for (Eigen::Index k = 0; k < 100; ++k) {
    const Eigen::Vector3d jitter(noise(rng), noise(rng), noise(rng));
    c.target_points.col(k) = (k < 40 ? upright : tipped) * c.source_points.col(k) + jitter;
  }
  MacParams params = test::roomScaleParams();
  const MacResult free = registerCorrespondences(c, params);
  params.evaluation.max_tilt_deg = 45.0;
  const MacResult prior = registerCorrespondences(c, params);
  ASSERT_TRUE(hasEstimate(free)) << free.message;
  ASSERT_TRUE(hasEstimate(prior)) << prior.message;
  EXPECT_LT(rotationErrorDeg(free.T_target_source, tipped), 2.0);
  EXPECT_EQ(free.counters.tilted_hypotheses, 0u);
  EXPECT_LT(rotationErrorDeg(prior.T_target_source, upright), 2.0);
  EXPECT_LT(translationError(prior.T_target_source, upright), 0.05);
  EXPECT_GT(prior.counters.tilted_hypotheses, 0u);
  EXPECT_LE(tiltDeg(prior.T_target_source), 45.0);
}

// Real FPFH correspondences of 3DMatch redkitchen fragments 24 -> 59: 5678 matches, 210 inliers (3.7 %).
TEST(RealCorrespondences, RedkitchenPairMeetsTheBenchmarkCriterion) {
  const CorrespondenceSet c = readCorrespondencesFile(dataPath("redkitchen_24_59/correspondences.txt"));
  const Eigen::Isometry3d truth = readTransformFile(dataPath("redkitchen_24_59/T_target_source_gt.txt"));
  ASSERT_EQ(c.size(), 5678u);
  MacParams params;  // defaults are the indoor ones: tau 0.1 m
  params.graph.gaussian_sigma = 0.05;
  const MacResult result = registerCorrespondences(c, params);
  ASSERT_TRUE(result.success) << result.message;
  // 3DMatch registration recall criterion.
  EXPECT_LE(rotationErrorDeg(result.T_target_source, truth), 15.0);
  EXPECT_LE(translationError(result.T_target_source, truth), 0.30);
  EXPECT_GE(result.counters.inliers, 150u);
}

}  // namespace
}  // namespace mac_registration
