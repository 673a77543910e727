// Hypothesis scoring (paper Sec. 3.4) on correspondences with residuals known by construction.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <vector>

#include "evaluation.hpp"

namespace mac_registration {
namespace {

const Eigen::Isometry3d kT = Eigen::Translation3d(1.0, 2.0, -0.5) *
                             Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.0, 1.0, 1.0).normalized());

// Residuals under kT, each along a coordinate axis so that its length is exact. With tau = 0.1 the
// first four are inliers (0.09 < 0.1, and 0.15, 0.5 are not).
const std::vector<double> kResiduals = {0.0, 0.02, 0.05, 0.09, 0.15, 0.5};

CorrespondenceSet withResiduals(const Eigen::Vector3d& offset) {
  const int n = static_cast<int>(kResiduals.size());
  CorrespondenceSet c;
  c.source_points.resize(3, n);
  c.target_points.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d s = offset + Eigen::Vector3d(0.3 * i, 1.0 - 0.4 * i, (i % 2 ? 0.7 : -0.6));
    c.source_points.col(i) = s;
    c.target_points.col(i) = kT * s + kResiduals[i] * Eigen::Vector3d::Unit(i % 3);
  }
  return c;
}

EvaluationParams paramsFor(ScoreMetric metric) {
  EvaluationParams params;
  params.metric = metric;
  params.inlier_threshold = 0.1;
  return params;
}

// The evaluator works in float on centred points of O(1) m: residuals are good to ~1e-6 m, so each
// (tau - r) / tau term to ~1e-5; 1e-4 on a sum of four terms is safe and far below any term's size.
constexpr double kScoreTol = 1e-4;
constexpr double kResidualTol = 1e-5;

TEST(HypothesisEvaluator, MaeByHand) {
  const HypothesisEvaluator evaluator(withResiduals(Eigen::Vector3d::Zero()), paramsFor(ScoreMetric::kMAE));
  const HypothesisScore s = evaluator.score(kT);
  EXPECT_NEAR(s.score, 1.0 + 0.8 + 0.5 + 0.1, kScoreTol);
  EXPECT_EQ(s.inliers, 4u);
}

TEST(HypothesisEvaluator, MseByHand) {
  const HypothesisEvaluator evaluator(withResiduals(Eigen::Vector3d::Zero()), paramsFor(ScoreMetric::kMSE));
  const HypothesisScore s = evaluator.score(kT);
  EXPECT_NEAR(s.score, 1.0 + 0.64 + 0.25 + 0.01, kScoreTol);
  EXPECT_EQ(s.inliers, 4u);
}

TEST(HypothesisEvaluator, InlierCountByHand) {
  const HypothesisEvaluator evaluator(withResiduals(Eigen::Vector3d::Zero()),
                                      paramsFor(ScoreMetric::kInlierCount));
  const HypothesisScore s = evaluator.score(kT);
  EXPECT_EQ(s.score, 4.0);
  EXPECT_EQ(s.inliers, 4u);
}

TEST(HypothesisEvaluator, InliersAndResiduals) {
  const HypothesisEvaluator evaluator(withResiduals(Eigen::Vector3d::Zero()), paramsFor(ScoreMetric::kMAE));
  EXPECT_EQ(evaluator.inliers(kT), (std::vector<int>{0, 1, 2, 3}));
  const std::vector<double> r = evaluator.residuals(kT);
  ASSERT_EQ(r.size(), kResiduals.size());
  for (std::size_t i = 0; i < r.size(); ++i) EXPECT_NEAR(r[i], kResiduals[i], kResidualTol) << "i = " << i;

  // A transform 10 m off has no inlier and scores 0.
  const Eigen::Isometry3d far = Eigen::Translation3d(10.0, 0.0, 0.0) * kT;
  EXPECT_TRUE(evaluator.inliers(far).empty());
  EXPECT_EQ(evaluator.score(far).score, 0.0);
  EXPECT_EQ(evaluator.score(far).inliers, 0u);
}

// Map-sized coordinates: 1e5 m offsets. Plain float would have a ulp of ~1.6e-2 m there; centring must
// keep residuals to the millimetre (they are in fact good to ~1e-6 m).
TEST(HypothesisEvaluator, LargeCoordinatesKeepMillimetres) {
  const HypothesisEvaluator evaluator(withResiduals(Eigen::Vector3d(1e5, -2e5, 3e4)),
                                      paramsFor(ScoreMetric::kMAE));
  const std::vector<double> r = evaluator.residuals(kT);
  ASSERT_EQ(r.size(), kResiduals.size());
  for (std::size_t i = 0; i < r.size(); ++i) EXPECT_NEAR(r[i], kResiduals[i], 1e-3) << "i = " << i;
  EXPECT_EQ(evaluator.inliers(kT), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_NEAR(evaluator.score(kT).score, 2.4, 1e-2);  // 1 mm per residual is 1e-2 per MAE term
}

TEST(BestHypothesis, HighestScoreEarliestAmongEquals) {
  const auto scores = [](std::vector<double> values) {
    std::vector<HypothesisScore> out;
    for (double v : values) out.push_back({v, 0});
    return out;
  };
  EXPECT_EQ(bestHypothesis(scores({1.0, 3.0, 3.0, 2.0})), 1);
  EXPECT_EQ(bestHypothesis(scores({5.0, 5.0, 7.0, 7.0})), 2);
  EXPECT_EQ(bestHypothesis(scores({0.0, 0.0})), 0);
  EXPECT_EQ(bestHypothesis(scores({-1.0, -0.5})), 1);
  EXPECT_EQ(bestHypothesis({}), -1);
}

// score() and inliers() must agree on a residual just below tau: for r^2 one float step below tau^2,
// sqrtf(r^2) rounds to tau, so a test on sqrt would call it an outlier while r^2 < tau^2 calls it an inlier.
// Found by a random search near |r| = tau.
TEST(HypothesisEvaluator, ScoreAndInliersAgreeAtThreshold) {
  CorrespondenceSet c;
  c.source_points = Eigen::Matrix3Xd::Zero(3, 1);
  c.target_points.resize(3, 1);
  c.target_points.col(0) = Eigen::Vector3d(-0.046378090554831899, -0.088594989415602607, 0.0);
  const HypothesisEvaluator evaluator(c, paramsFor(ScoreMetric::kInlierCount));
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  ASSERT_LT(evaluator.residuals(identity)[0], 0.1);
  EXPECT_EQ(evaluator.inliers(identity).size(), 1u);
  EXPECT_EQ(evaluator.score(identity).inliers, evaluator.inliers(identity).size());
}

}  // namespace
}  // namespace mac_registration
