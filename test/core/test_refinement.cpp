// Iteratively reweighted SVD refinement: never worse than the initial transform, better on a perturbed one.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "hypotheses.hpp"
#include "refinement.hpp"

namespace mac_registration {
namespace {

const Eigen::Isometry3d kTruth =
    Eigen::Translation3d(0.4, -0.3, 1.1) * Eigen::AngleAxisd(0.9, Eigen::Vector3d(-1, 2, 1).normalized());

// 200 correspondences in a 2 m cube, the first 120 inliers with 1 cm Gaussian noise per axis, the rest
// uniform outliers. Fixed seed.
CorrespondenceSet noisyProblem() {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  CorrespondenceSet c;
  c.source_points.resize(3, 200);
  c.target_points.resize(3, 200);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d s(u(rng), u(rng), u(rng));
    c.source_points.col(i) = s;
    c.target_points.col(i) =
        i < 120 ? Eigen::Vector3d(kTruth * s + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)))
                : Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  return c;
}

constexpr double kDegree = 3.14159265358979323846 / 180.0;

double rotationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

struct RefineTransform : ::testing::Test {
  CorrespondenceSet c = noisyProblem();
  EvaluationParams evaluation;  // MAE, tau = 0.1
  HypothesisEvaluator evaluator{c, evaluation};
  RefinementParams params;

  RefinementOutcome refine(const Eigen::Isometry3d& initial) const {
    return refineTransform(initial, evaluator.score(initial), c, evaluator, evaluation, params);
  }
};

TEST_F(RefineTransform, ImprovesPerturbedTransform) {
  // 2 degrees and 3 cm off: most inliers are still within tau, so refinement has something to work on.
  const Eigen::Isometry3d initial =
      Eigen::Translation3d(0.03, 0.0, -0.01) * kTruth * Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitX());
  const HypothesisScore initial_score = evaluator.score(initial);
  const RefinementOutcome out = refine(initial);
  EXPECT_GT(out.score.score, initial_score.score);
  EXPECT_GE(out.improvements, 1);
  EXPECT_LE(out.iterations, params.max_iterations);
  EXPECT_GE(out.score.inliers, initial_score.inliers);
  // With 120 inliers at 1 cm noise the least-squares fit lands within ~2 mm and ~0.1 deg of the truth;
  // 1 cm and 0.5 deg are loose bounds that the 3 cm / 2 deg initial guess does not meet.
  EXPECT_LT((out.T_target_source.translation() - kTruth.translation()).norm(), 0.01);
  EXPECT_LT(rotationError(out.T_target_source, kTruth), 0.5 * kDegree);
  EXPECT_GT(rotationError(initial, kTruth), 0.5 * kDegree);
  // The reported score is the score of the returned transform (float evaluation is deterministic).
  EXPECT_EQ(out.score.score, evaluator.score(out.T_target_source).score);
  EXPECT_NEAR(out.T_target_source.linear().determinant(), 1.0, 1e-9);
}

TEST_F(RefineTransform, NeverWorseThanInitial) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Eigen::Isometry3d> initials = {kTruth, Eigen::Isometry3d::Identity()};  // exact; hopeless
  for (int k = 0; k < 20; ++k) {  // random perturbations from 0.5 deg / 5 mm to ~10 deg / 10 cm
    const double scale = 0.01 + 0.01 * k;
    const Eigen::Vector3d axis = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    initials.push_back(Eigen::Translation3d(scale * Eigen::Vector3d(n(rng), n(rng), n(rng))) * kTruth *
                       Eigen::AngleAxisd(scale * 0.9, axis));
  }
  for (std::size_t k = 0; k < initials.size(); ++k) {
    const HypothesisScore initial_score = evaluator.score(initials[k]);
    const RefinementOutcome out = refine(initials[k]);
    EXPECT_GE(out.score.score, initial_score.score) << "initial " << k;
    EXPECT_EQ(out.score.score, evaluator.score(out.T_target_source).score) << "initial " << k;
    if (out.improvements == 0) {
      EXPECT_TRUE(out.T_target_source.matrix() == initials[k].matrix()) << "initial " << k;
    }
  }
}

TEST_F(RefineTransform, NoInliersReturnsInitialUnchanged) {
  const Eigen::Isometry3d far = Eigen::Translation3d(50.0, 0.0, 0.0) * kTruth;
  const RefinementOutcome out = refine(far);
  EXPECT_EQ(out.improvements, 0);
  EXPECT_EQ(out.iterations, 1);
  EXPECT_TRUE(out.T_target_source.matrix() == far.matrix());
  EXPECT_EQ(out.score.score, 0.0);
}

TEST_F(RefineTransform, IterationCapIsRespected) {
  params.max_iterations = 1;
  const Eigen::Isometry3d initial = Eigen::Translation3d(0.04, 0.02, 0.0) * kTruth;
  const RefinementOutcome out = refine(initial);
  EXPECT_EQ(out.iterations, 1);
  EXPECT_LE(out.improvements, 1);
  EXPECT_GE(out.score.score, evaluator.score(initial).score);
}

// A refit that scores worse must be refused. Ten exact correspondences and five shifted by 9 cm (inliers,
// just under tau): the reweighted least-squares fit is pulled ~2 cm towards the shifted five, which costs
// the exact ten more MAE than the five gain, so the initial (true) transform must come back unchanged.
TEST(RefineTransformAlone, WorseRefitIsRejected) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  CorrespondenceSet c;
  c.source_points.resize(3, 15);
  c.target_points.resize(3, 15);
  for (int i = 0; i < 15; ++i) {
    const Eigen::Vector3d s(u(rng), u(rng), u(rng));
    c.source_points.col(i) = s;
    c.target_points.col(i) =
        kTruth * s + (i < 10 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0.09, 0.0, 0.0));
  }
  const EvaluationParams evaluation;  // MAE, tau = 0.1
  const HypothesisEvaluator evaluator(c, evaluation);
  const HypothesisScore initial_score = evaluator.score(kTruth);
  ASSERT_EQ(initial_score.inliers, 15u);

  // Precondition: the refit the first round computes is indeed worse.
  const std::vector<double> r = evaluator.residuals(kTruth);
  std::vector<double> weights(15);
  for (int i = 0; i < 15; ++i) weights[i] = 1.0 / (1.0 + (r[i] / 0.1) * (r[i] / 0.1));
  const auto refit = estimateRigidTransform(c, evaluator.inliers(kTruth), weights);
  ASSERT_TRUE(refit.has_value());
  ASSERT_LT(evaluator.score(*refit).score, initial_score.score);

  const RefinementOutcome out = refineTransform(kTruth, initial_score, c, evaluator, evaluation, {});
  EXPECT_EQ(out.improvements, 0);
  EXPECT_EQ(out.iterations, 1);
  EXPECT_TRUE(out.T_target_source.matrix() == kTruth.matrix());
  EXPECT_EQ(out.score.score, initial_score.score);
}

// The tilt prior holds in the refinement too: correspondences that fit a pose tipped 50 deg, all inliers of
// an upright-enough start at 40 deg (points within 0.3 m: 10 deg moves them 5 cm, under tau). Without the
// prior the refit reaches 50 deg; with a 45 deg prior it stays where it started. A start already tipped (a
// rival judged beside the answer) refines as without the prior.
TEST(RefineTransformAlone, StopsAtTheTiltPrior) {
  const Eigen::Isometry3d tipped(Eigen::AngleAxisd(50.0 * kDegree, Eigen::Vector3d::UnitX()));
  const Eigen::Isometry3d start(Eigen::AngleAxisd(40.0 * kDegree, Eigen::Vector3d::UnitX()));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.17, 0.17);
  CorrespondenceSet c;
  c.source_points.resize(3, 40);
  c.target_points.resize(3, 40);
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d s(u(rng), u(rng), u(rng));
    c.source_points.col(i) = s;
    c.target_points.col(i) = tipped * s;
  }
  EvaluationParams evaluation;  // MAE, tau = 0.1
  for (const double prior : {180.0, 45.0}) {
    evaluation.max_tilt_deg = prior;
    const HypothesisEvaluator evaluator(c, evaluation);
    ASSERT_EQ(evaluator.score(start).inliers, 40u);
    const RefinementOutcome out =
        refineTransform(start, evaluator.score(start), c, evaluator, evaluation, {});
    if (prior >= 180.0) {
      EXPECT_GE(out.improvements, 1);
      EXPECT_LT(rotationError(out.T_target_source, tipped), 0.1 * kDegree);
    } else {
      EXPECT_EQ(out.improvements, 0);
      EXPECT_TRUE(out.T_target_source.matrix() == start.matrix());
      const Eigen::Isometry3d rival(Eigen::AngleAxisd(60.0 * kDegree, Eigen::Vector3d::UnitX()));
      const RefinementOutcome tipped_out =
          refineTransform(rival, evaluator.score(rival), c, evaluator, evaluation, {});
      EXPECT_LT(rotationError(tipped_out.T_target_source, tipped), 0.1 * kDegree);
    }
  }
}

// The refinement as specified, each round from fresh vectors: inliers(), residuals() and the weights
// 1 / (1 + (r / tau)^2) on the inliers. The refinement's reused buffers must give the same rounds, bit
// for bit.
RefinementOutcome refinedFromFreshVectors(const Eigen::Isometry3d& initial, const CorrespondenceSet& c,
                                          const HypothesisEvaluator& evaluator, double tau, int rounds) {
  RefinementOutcome best{initial, evaluator.score(initial), 0, 0};
  for (int round = 0; round < rounds; ++round) {
    best.iterations = round + 1;
    const std::vector<int> inliers = evaluator.inliers(best.T_target_source);
    const std::vector<double> residuals = evaluator.residuals(best.T_target_source);
    std::vector<double> weights(residuals.size(), 0.0);
    for (int i : inliers) weights[i] = 1.0 / (1.0 + (residuals[i] / tau) * (residuals[i] / tau));
    const auto candidate = estimateRigidTransform(c, inliers, weights);
    if (!candidate) break;
    const HypothesisScore score = evaluator.score(*candidate);
    if (!(score.score > best.score.score)) break;
    best.T_target_source = *candidate;
    best.score = score;
    ++best.improvements;
  }
  return best;
}

TEST_F(RefineTransform, SameRoundsAsFreshVectorsEachRound) {
  for (const double angle : {0.0, 0.02, 0.05}) {
    const Eigen::Isometry3d initial = kTruth *
                                      Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 1, 0).normalized()) *
                                      Eigen::Translation3d(0.01, 0, 0);
    const RefinementOutcome expected =
        refinedFromFreshVectors(initial, c, evaluator, evaluation.inlier_threshold, params.max_iterations);
    EXPECT_GE(expected.improvements, 1) << "angle " << angle;  // rounds that reweight a moved pose
    const RefinementOutcome got = refine(initial);
    EXPECT_EQ(got.iterations, expected.iterations) << "angle " << angle;
    EXPECT_EQ(got.improvements, expected.improvements) << "angle " << angle;
    EXPECT_EQ(got.score.score, expected.score.score) << "angle " << angle;
    EXPECT_EQ(got.T_target_source.matrix(), expected.T_target_source.matrix()) << "angle " << angle;
  }
}

// inlierWeights and squaredResiduals compute the residuals in a vectorized pass: the same inliers and, bit
// for bit, the weights and squares of the scalar residuals(), for a pose with a rotation too, and on a count
// that leaves a vector tail.
TEST(HypothesisEvaluatorWeights, InlierWeightsMatchInliersAndResiduals) {
  const int n = 301;
  const Eigen::Isometry3d moved = Eigen::Translation3d(0.3, -0.2, 0.1) *
                                  Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, 3.0).normalized());
  for (const Eigen::Isometry3d& T : {Eigen::Isometry3d(Eigen::Isometry3d::Identity()), moved}) {
    CorrespondenceSet c;
    c.source_points = Eigen::Matrix3Xd::Random(3, n);
    c.target_points = T * c.source_points + 0.08 * Eigen::Matrix3Xd::Random(3, n);
    EvaluationParams p;
    p.inlier_threshold = 0.1;
    const HypothesisEvaluator e(c, p);
    std::vector<int> indices = {7, 8};  // stale content is replaced
    std::vector<double> weights(5, 3.0);
    e.inlierWeights(T, 0.07, indices, weights);
    EXPECT_EQ(indices, e.inliers(T));
    ASSERT_GT(indices.size(), 10u);
    ASSERT_LT(indices.size(), std::size_t(n));
    const std::vector<double> r = e.residuals(T);
    ASSERT_EQ(weights.size(), std::size_t(n));
    std::vector<char> inlier(n, 0);
    for (int i : indices) inlier[i] = 1;
    for (int i = 0; i < n; ++i)
      EXPECT_EQ(weights[i], inlier[i] ? 1.0 / (1.0 + (r[i] / 0.07) * (r[i] / 0.07)) : 0.0) << "i = " << i;
    std::vector<double> squared(3, -1.0);
    e.squaredResiduals(T, squared);
    ASSERT_EQ(squared.size(), std::size_t(n));
    for (int i = 0; i < n; ++i) EXPECT_EQ(std::sqrt(squared[i]), r[i]) << "i = " << i;
  }
}

}  // namespace
}  // namespace mac_registration
