// The RANSAC baseline: right on easy sets, deterministic, explicit about failures.
#include <gtest/gtest.h>

#include "../core/test_support.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "ransac_baseline.hpp"

namespace mac_registration {
namespace {

SyntheticProblem roomScaleProblem(int n, double inlier_ratio, std::uint32_t seed) {
  return makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(n, inlier_ratio, seed));
}

TEST(RansacBaseline, RecoversTheTransformOfAnEasySet) {
  const SyntheticProblem problem = roomScaleProblem(1000, 0.3, 5);
  RansacParams params;
  params.inlier_threshold = 0.05;  // 10 noise sigmas
  const MacResult r = registerCorrespondencesRansac(problem.correspondences, params);
  ASSERT_TRUE(r.success) << r.message;
  // 300 inliers at 5 mm noise on a 3 m object: the refit is far within 1 deg / 2 cm.
  EXPECT_LT(rotationErrorDeg(r.T_target_source, problem.T_target_source), 1.0);
  EXPECT_LT(translationError(r.T_target_source, problem.T_target_source), 0.02);
  EXPECT_NEAR(r.T_target_source.linear().determinant(), 1.0, 1e-9);
  // Inliers counted at the given threshold: the true inliers, and outliers only by chance.
  std::size_t true_inliers = 0;
  for (int i : r.inlier_indices) true_inliers += problem.is_inlier[i];
  EXPECT_GE(true_inliers, 290u);
  EXPECT_EQ(r.counters.inliers, r.inlier_indices.size());
  EXPECT_GT(r.times.total_ms, 0.0);

  const MacResult again = registerCorrespondencesRansac(problem.correspondences, params);
  EXPECT_TRUE(again.T_target_source.matrix() == r.T_target_source.matrix());  // seeded: bitwise equal
}

TEST(RansacBaseline, InlierIndicesReferToTheCallersSetDespiteNaNs) {
  SyntheticProblem problem = roomScaleProblem(300, 0.5, 9);
  problem.correspondences.source_points(0, 0) = std::numeric_limits<double>::quiet_NaN();
  RansacParams params;
  params.inlier_threshold = 0.05;
  const MacResult r = registerCorrespondencesRansac(problem.correspondences, params);
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.counters.dropped_non_finite, 1u);
  for (int i : r.inlier_indices) {
    ASSERT_NE(i, 0);
    const Eigen::Vector3d residual = r.T_target_source * problem.correspondences.source_points.col(i) -
                                     problem.correspondences.target_points.col(i);
    EXPECT_LT(residual.norm(), params.inlier_threshold);
  }
}

TEST(RansacBaseline, FailuresAreExplicit) {
  CorrespondenceSet two;
  two.source_points = Eigen::Matrix3Xd::Random(3, 2);
  two.target_points = two.source_points;
  EXPECT_EQ(registerCorrespondencesRansac(two, RansacParams{}).status,
            RegistrationStatus::kTooFewCorrespondences);

  RansacParams bad;
  bad.inlier_threshold = 0.0;
  const MacResult r = registerCorrespondencesRansac(roomScaleProblem(50, 0.5, 1).correspondences, bad);
  EXPECT_EQ(r.status, RegistrationStatus::kInvalidParameters);
  EXPECT_FALSE(r.success);

  // Demanding more inliers than exist: the best model is returned, marked as too few inliers.
  RansacParams strict;
  strict.inlier_threshold = 0.05;
  strict.min_inliers = 400;
  const MacResult few = registerCorrespondencesRansac(roomScaleProblem(500, 0.5, 2).correspondences, strict);
  EXPECT_EQ(few.status, RegistrationStatus::kTooFewInliers);
  EXPECT_FALSE(few.success);
}

}  // namespace
}  // namespace mac_registration
