// Rigid transform estimation (Kabsch/SVD) and the eigenvector weights of the weighted SVD.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <random>
#include <vector>

#include "graph_builders.hpp"
#include "hypotheses.hpp"

namespace mac_registration {
namespace {

// Everything below runs in double on O(1) coordinates with a well-conditioned covariance: the SVD is
// accurate to ~1e-14, so 1e-9 leaves ample margin yet would catch any single-precision step (~1e-7).
constexpr double kTol = 1e-9;

const Eigen::Isometry3d kTruth =
    Eigen::Translation3d(0.5, -1.2, 2.0) * Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized());

CorrespondenceSet fromPoints(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target) {
  CorrespondenceSet c;
  c.source_points = source;
  c.target_points = target;
  return c;
}

Eigen::Matrix3Xd randomPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

std::vector<int> all(int n) {
  std::vector<int> v(n);
  for (int i = 0; i < n; ++i) v[i] = i;
  return v;
}

void expectTransformNear(const Eigen::Isometry3d& actual, const Eigen::Isometry3d& expected, double tol) {
  EXPECT_LT((actual.linear() - expected.linear()).cwiseAbs().maxCoeff(), tol);
  EXPECT_LT((actual.translation() - expected.translation()).cwiseAbs().maxCoeff(), tol);
}

TEST(EstimateRigidTransform, RecoversExactTransform) {
  const Eigen::Matrix3Xd source = randomPoints(6, 11);
  const auto T = estimateRigidTransform(fromPoints(source, kTruth * source), all(6));
  ASSERT_TRUE(T.has_value());
  expectTransformNear(*T, kTruth, kTol);
}

TEST(EstimateRigidTransform, ThreeNonCollinearPointsSuffice) {
  Eigen::Matrix3Xd source(3, 3);
  source << 0, 1, 0,  //
      0, 0, 2,        //
      0, 0, 0;        // coplanar (three points always are) but not collinear
  const auto T = estimateRigidTransform(fromPoints(source, kTruth * source), all(3));
  ASSERT_TRUE(T.has_value());
  expectTransformNear(*T, kTruth, kTol);
}

TEST(EstimateRigidTransform, OnlyGivenIndicesAreUsed) {
  Eigen::Matrix3Xd source = randomPoints(8, 12);
  Eigen::Matrix3Xd target = kTruth * source;
  target.col(2) += Eigen::Vector3d(3.0, -1.0, 0.5);  // outliers, not among the indices
  target.col(5) = Eigen::Vector3d(9.0, 9.0, 9.0);
  const auto T = estimateRigidTransform(fromPoints(source, target), {0, 1, 3, 4, 6, 7});
  ASSERT_TRUE(T.has_value());
  expectTransformNear(*T, kTruth, kTol);
}

TEST(EstimateRigidTransform, ReflectionGivesProperRotation) {
  // Spread 0.1 along x, 1 along y, 2 along z; the target mirrors x. The nearest proper rotation flips
  // the axis of least spread back, i.e. x: the identity.
  Eigen::Matrix3Xd source(3, 6);
  source << 0.1, -0.1, 0, 0, 0, 0,  //
      0, 0, 1, -1, 0, 0,            //
      0, 0, 0, 0, 2, -2;
  const Eigen::Matrix3Xd target = Eigen::Vector3d(-1, 1, 1).asDiagonal() * source;
  const auto T = estimateRigidTransform(fromPoints(source, target), all(6));
  ASSERT_TRUE(T.has_value());
  EXPECT_NEAR(T->linear().determinant(), 1.0, kTol);
  EXPECT_LT((T->linear().transpose() * T->linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(),
            kTol);
  expectTransformNear(*T, Eigen::Isometry3d::Identity(), kTol);
}

TEST(EstimateRigidTransform, ZeroWeightsExcludeOutliers) {
  const Eigen::Matrix3Xd source = randomPoints(8, 13);
  Eigen::Matrix3Xd target = kTruth * source;
  target.col(1) += Eigen::Vector3d(2.0, 0.0, -1.0);
  target.col(6) += Eigen::Vector3d(-0.5, 1.5, 0.7);
  const CorrespondenceSet c = fromPoints(source, target);
  // Unequal weights on the inliers do not matter for exact data; zero weights remove the outliers.
  const std::vector<double> weights = {1.0, 0.0, 0.5, 2.0, 1.0, 3.0, 0.0, 0.25};
  const auto T = estimateRigidTransform(c, all(8), weights);
  ASSERT_TRUE(T.has_value());
  expectTransformNear(*T, kTruth, kTol);
  // Control: with equal weights the outliers do pull the estimate away.
  const auto unweighted = estimateRigidTransform(c, all(8));
  ASSERT_TRUE(unweighted.has_value());
  EXPECT_GT((unweighted->translation() - kTruth.translation()).norm(), 1e-2);
}

TEST(EstimateRigidTransform, DegenerateInputsGiveNothing) {
  const Eigen::Matrix3Xd source = randomPoints(4, 14);
  const CorrespondenceSet good = fromPoints(source, kTruth * source);
  EXPECT_FALSE(estimateRigidTransform(good, {}).has_value());
  EXPECT_FALSE(estimateRigidTransform(good, {0, 1}).has_value());
  EXPECT_FALSE(estimateRigidTransform(good, all(4), {0.0, 0.0, 0.0, 0.0}).has_value());  // no weight

  const Eigen::Matrix3Xd same = Eigen::Vector3d(1.0, 2.0, 3.0).replicate(1, 4);
  EXPECT_FALSE(estimateRigidTransform(fromPoints(same, kTruth * same), all(4)).has_value());

  Eigen::Matrix3Xd line(3, 4);
  for (int i = 0; i < 4; ++i)
    line.col(i) = Eigen::Vector3d(1.0, 2.0, 3.0) + i * Eigen::Vector3d(0.3, -0.2, 0.5);
  EXPECT_FALSE(estimateRigidTransform(fromPoints(line, kTruth * line), all(4)).has_value());
}

// Two triangles sharing an edge plus a pendant node, and an isolated node 5; not bipartite, so power
// iteration converges.
CompatibilityGraph smallGraph() {
  return graphFromUpperRows(
      6, {{{1, 0.5f}, {2, 0.8f}}, {{2, 0.9f}, {3, 0.6f}}, {{3, 0.7f}}, {{4, 1.0f}}, {}, {}});
}

TEST(PrincipalEigenvector, MatchesDenseEigenSolver) {
  const CompatibilityGraph g = smallGraph();
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(6, 6);
  for (int i = 0; i < 6; ++i) {
    for (auto p = g.offsets[i]; p < g.offsets[i + 1]; ++p) dense(i, g.neighbours[p]) = g.weights[p];
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(dense);
  Eigen::VectorXd expected = solver.eigenvectors().col(5);                         // largest eigenvalue last
  expected /= expected.cwiseAbs().maxCoeff() * (expected.sum() < 0 ? -1.0 : 1.0);  // max 1, positive

  // Power iteration error shrinks as (|l2| / l1)^k; 200 rounds reach double precision on this graph.
  const std::vector<double> v = principalEigenvector(g, 200);
  ASSERT_EQ(v.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(v[i], expected(i), kTol) << "node " << i;
  EXPECT_EQ(v[5], 0.0);  // isolated
  EXPECT_DOUBLE_EQ(*std::max_element(v.begin(), v.end()), 1.0);

  // The default 50 rounds: |l2| / l1 = 0.69 here, so the error is ~0.69^50 = 1e-8; 1e-6 is safe.
  const std::vector<double> v50 = principalEigenvector(g);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(v50[i], expected(i), 1e-6) << "node " << i;
}

TEST(PrincipalEigenvector, EdgelessGraphGivesZeros) {
  EXPECT_EQ(principalEigenvector(graphFromUpperRows(3, {{}, {}, {}})), (std::vector<double>{0.0, 0.0, 0.0}));
}

}  // namespace
}  // namespace mac_registration
