// The first-order compatibility graph (paper Eq. 1-2) on hand-made inputs, against the pair-by-pair test,
// and its bounds.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "compatibility_graph.hpp"
#include "graph_bounds.hpp"
#include "graph_builders.hpp"
#include "graph_test_support.hpp"

namespace mac_registration {
namespace {

using test::expectValidGraph;

// Five correspondences on a line: source at x_i, target at y_i = x_i + e_i along another direction in
// another frame. With spacing 1 >> e, d_ij = | |x_i-x_j| - |y_i-y_j| | = |e_i - e_j| exactly:
// d01 = 0.02, d02 = 0.05, d12 = 0.03, d34 = 0.01, every other pair >= 0.25.
CorrespondenceSet lineCorrespondences(const std::vector<double>& e) {
  const Eigen::Vector3d direction = Eigen::Vector3d(1.0, 2.0, 2.0) / 3.0;
  const Eigen::Vector3d origin(5.0, -3.0, 1.0);
  CorrespondenceSet c;
  c.source_points.resize(3, static_cast<Eigen::Index>(e.size()));
  c.target_points.resize(3, static_cast<Eigen::Index>(e.size()));
  for (std::size_t i = 0; i < e.size(); ++i) {
    const double x = static_cast<double>(i);
    c.source_points.col(i) = Eigen::Vector3d(x, 0.0, 0.0);
    c.target_points.col(i) = origin + (x + e[i]) * direction;
  }
  return c;
}

const std::vector<double> kOffsets = {0.0, 0.02, 0.05, 0.3, 0.31};

// Points are centred and stored in float (ulp ~2.4e-7 at 2 m), so d carries ~1e-6 error and the
// weights ~1e-5 at most: 5e-5 tolerates that and still tells exp(-d^2/2s^2) from exp(-d^2/s^2).
constexpr double kWeightTol = 5e-5;

TEST(FirstOrderGraph, GaussianWeightsByHand) {
  GraphParams params;
  params.score = CompatibilityScore::kGaussian;
  params.gaussian_sigma = 0.1;
  params.t_cmp = 0.5;  // d <= 0.1 * sqrt(2 ln 2) = 0.1177: pairs 01, 02, 12, 34
  const FirstOrderGraph fog = buildFirstOrderGraph(lineCorrespondences(kOffsets), params, 1);
  expectValidGraph(fog.graph);
  EXPECT_FALSE(fog.reduced);
  ASSERT_EQ(fog.graph.num_nodes, 5);
  EXPECT_EQ(fog.graph.numEdges(), 4u);
  EXPECT_NEAR(fog.graph.weight(0, 1), std::exp(-0.02 * 0.02 / 0.02), kWeightTol);  // 0.98020
  EXPECT_NEAR(fog.graph.weight(0, 2), std::exp(-0.05 * 0.05 / 0.02), kWeightTol);  // 0.88250
  EXPECT_NEAR(fog.graph.weight(1, 2), std::exp(-0.03 * 0.03 / 0.02), kWeightTol);  // 0.95600
  EXPECT_NEAR(fog.graph.weight(3, 4), std::exp(-0.01 * 0.01 / 0.02), kWeightTol);  // 0.99501
  EXPECT_EQ(fog.graph.weight(2, 3), 0.0f);
  EXPECT_EQ(fog.graph.weight(0, 4), 0.0f);
  EXPECT_EQ(fog.graph.neighbours, (std::vector<int>{1, 2, 0, 2, 0, 1, 4, 3}));
}

TEST(FirstOrderGraph, QuadraticWeightsByHand) {
  GraphParams params;
  params.score = CompatibilityScore::kQuadratic;
  params.quadratic_threshold = 0.1;
  params.t_cmp = 0.8;  // d <= 0.1 * sqrt(0.2) = 0.0447: pairs 01, 12, 34 but not 02 (d = 0.05)
  const FirstOrderGraph fog = buildFirstOrderGraph(lineCorrespondences(kOffsets), params, 1);
  expectValidGraph(fog.graph);
  EXPECT_EQ(fog.graph.numEdges(), 3u);
  EXPECT_NEAR(fog.graph.weight(0, 1), 1.0 - 0.02 * 0.02 / 0.01, kWeightTol);  // 0.96
  EXPECT_NEAR(fog.graph.weight(1, 2), 1.0 - 0.03 * 0.03 / 0.01, kWeightTol);  // 0.91
  EXPECT_NEAR(fog.graph.weight(3, 4), 1.0 - 0.01 * 0.01 / 0.01, kWeightTol);  // 0.99
  EXPECT_EQ(fog.graph.weight(0, 2), 0.0f);
}

// An edge exactly where S >= t_cmp: residuals 0.1% below and above the bound on d. The margin (>= 3e-5 m)
// is over an order above the float error of d (~1e-6 m), so the outcome is not decided by rounding.
TEST(FirstOrderGraph, EdgeExactlyWhereScoreReachesThreshold) {
  for (const auto score : {CompatibilityScore::kGaussian, CompatibilityScore::kQuadratic}) {
    GraphParams params;
    params.score = score;
    params.gaussian_sigma = 0.1;
    params.quadratic_threshold = 0.1;
    params.t_cmp = 0.9;
    const double d_max = score == CompatibilityScore::kGaussian ? 0.1 * std::sqrt(-2.0 * std::log(0.9))
                                                                : 0.1 * std::sqrt(1.0 - 0.9);
    // d01 just inside, d02 just outside, d12 ~ 2 d_max.
    const auto c = lineCorrespondences({0.0, d_max * (1.0 - 1e-3), -d_max * (1.0 + 1e-3)});
    const FirstOrderGraph fog = buildFirstOrderGraph(c, params, 1);
    EXPECT_EQ(fog.graph.numEdges(), 1u);
    EXPECT_GT(fog.graph.weight(0, 1), 0.0f);
    EXPECT_NEAR(fog.graph.weight(0, 1), 0.9, 1e-3);  // S at the bound is t_cmp
    EXPECT_GE(fog.graph.weight(0, 1), 0.9 - 1e-5);
    EXPECT_EQ(fog.graph.weight(0, 2), 0.0f);
    EXPECT_EQ(fog.graph.weight(1, 2), 0.0f);
  }
}

// Random rigid problem: the first `inliers` targets are R s + t, the rest uniform. Fixed seed.
CorrespondenceSet rigidProblem(int n, int inliers, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Isometry3d T =
      Eigen::Translation3d(0.3, -0.2, 0.5) * Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized());
  CorrespondenceSet c;
  c.source_points.resize(3, n);
  c.target_points.resize(3, n);
  for (int i = 0; i < n; ++i) {
    c.source_points.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
    c.target_points.col(i) = i < inliers ? Eigen::Vector3d(T * Eigen::Vector3d(c.source_points.col(i)))
                                         : Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  return c;
}

TEST(FirstOrderGraph, IdenticalForOneAndTwoThreads) {
  const CorrespondenceSet c = rigidProblem(300, 210, 7);
  const GraphParams params;  // Gaussian, sigma 0.1, t_cmp 0.99
  const FirstOrderGraph one = buildFirstOrderGraph(c, params, 1);
  const FirstOrderGraph two = buildFirstOrderGraph(c, params, 2);
  expectValidGraph(one.graph);
  EXPECT_GE(one.graph.numEdges(), 210u * 209u / 2u);  // every inlier pair is compatible
  EXPECT_EQ(one.graph.offsets, two.graph.offsets);
  EXPECT_EQ(one.graph.neighbours, two.graph.neighbours);
  EXPECT_EQ(one.graph.weights, two.graph.weights);  // bitwise: each pair is computed the same way

  const CompatibilityGraph sog1 = buildSecondOrderGraph(one.graph, 1);
  const CompatibilityGraph sog2 = buildSecondOrderGraph(one.graph, 2);
  expectValidGraph(sog1);
  EXPECT_EQ(sog1.neighbours, sog2.neighbours);
  EXPECT_EQ(sog1.weights, sog2.weights);
}

// Eq. 1-2 pair by pair in plain scalar float, as the graph defines them: points centred on their cloud's
// centroid and stored in float, d = | |s_i - s_j| - |t_i - t_j| |, an edge where d^2 is within the bound.
CompatibilityGraph pairByPairFirstOrder(const CorrespondenceSet& c, const GraphParams& params) {
  const int n = static_cast<int>(c.size());
  const Eigen::Vector3d s0 = c.source_points.rowwise().mean(), t0 = c.target_points.rowwise().mean();
  const Eigen::Matrix3Xf s = (c.source_points.colwise() - s0).cast<float>();
  const Eigen::Matrix3Xf t = (c.target_points.colwise() - t0).cast<float>();
  const bool gaussian = params.score == CompatibilityScore::kGaussian;
  const double sigma = params.gaussian_sigma, tau = params.quadratic_threshold;
  const auto max_d2 = static_cast<float>(gaussian ? -2.0 * sigma * sigma * std::log(params.t_cmp)
                                                  : (1.0 - params.t_cmp) * tau * tau);
  const auto distance = [](const Eigen::Matrix3Xf& p, int i, int j) {
    const float dx = p(0, i) - p(0, j), dy = p(1, i) - p(1, j), dz = p(2, i) - p(2, j);
    return std::sqrt(dx * dx + dy * dy + dz * dz);
  };
  std::vector<std::vector<UpperEdge>> rows(n);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const float d = distance(s, i, j) - distance(t, i, j), d2 = d * d;
      if (!(d2 <= max_d2)) continue;
      rows[i].push_back({j, gaussian ? std::exp(-d2 / static_cast<float>(2.0 * sigma * sigma))
                                     : 1.0f - d2 / static_cast<float>(tau * tau)});
    }
  }
  return graphFromUpperRows(n, rows);
}

// The pair test runs sixteen pairs at a time where the CPU has AVX-512 (rows of every length modulo 16
// here): the same edges and bit for bit the same weights as the pair-by-pair computation, either score.
TEST(FirstOrderGraph, BitIdenticalToThePairByPairTest) {
  for (const CompatibilityScore score : {CompatibilityScore::kGaussian, CompatibilityScore::kQuadratic}) {
    GraphParams params;
    params.score = score;
    params.gaussian_sigma = 0.3;
    params.quadratic_threshold = 0.3;
    params.t_cmp = 0.9;
    const CorrespondenceSet c = rigidProblem(237, 60, 5);
    const CompatibilityGraph expected = pairByPairFirstOrder(c, params);
    ASSERT_GT(expected.numEdges(), 60u * 59u / 2u);  // the inliers' pairs and some chance ones
    for (const int threads : {1, 2, 3}) {
      const FirstOrderGraph fog = buildFirstOrderGraph(c, params, threads);
      EXPECT_EQ(fog.graph.offsets, expected.offsets) << threads << " threads";
      EXPECT_EQ(fog.graph.neighbours, expected.neighbours) << threads << " threads";
      EXPECT_EQ(fog.graph.weights, expected.weights) << threads << " threads";
    }
  }
}

// Pairs whose d lies on the test's edge (offsets along a line that are multiples of the bound, a hair
// below, on and above it, where float rounding decides), at several distances and row lengths: the
// sixteen-pair rows keep exactly the pairs the pair-by-pair test keeps, bit for bit.
TEST(FirstOrderGraph, PairsOnTheBoundAreTheOnesThePairTestKeeps) {
  GraphParams params;
  params.gaussian_sigma = 0.05;
  const double bound = params.gaussian_sigma * std::sqrt(-2.0 * std::log(params.t_cmp));
  for (const double spacing : {0.3, 1.0, 7.0}) {
    for (const double factor : {1.0 - 1e-6, 1.0, 1.0 + 1e-6}) {
      // Source x_i = spacing i; target at spacing i + e_i along another direction: d_ij = |e_i - e_j|.
      const Eigen::Vector3d direction = Eigen::Vector3d(1.0, 2.0, 2.0) / 3.0;
      CorrespondenceSet c;
      c.source_points.resize(3, 203);
      c.target_points.resize(3, 203);
      for (int i = 0; i < 203; ++i) {
        const double e = double(i % 7) * bound * factor;
        c.source_points.col(i) = Eigen::Vector3d(spacing * i, 0.0, 0.0);
        c.target_points.col(i) = Eigen::Vector3d(5.0, -3.0, 1.0) + (spacing * i + e) * direction;
      }
      const CompatibilityGraph expected = pairByPairFirstOrder(c, params);
      ASSERT_GT(expected.numEdges(), 1000u) << spacing << " " << factor;
      for (const int threads : {1, 2}) {
        const FirstOrderGraph fog = buildFirstOrderGraph(c, params, threads);
        const std::string where = "spacing " + std::to_string(spacing) + ", factor " + std::to_string(factor);
        EXPECT_EQ(fog.graph.offsets, expected.offsets) << where;
        EXPECT_EQ(fog.graph.neighbours, expected.neighbours) << where;
        EXPECT_EQ(fog.graph.weights, expected.weights) << where;
      }
    }
  }
}

// A subset's floats are those of the whole set (centred on the centroid of all the correspondences), so
// the graph of an evenly spaced sample, or of the nodes a reduction keeps, is the pair-by-pair graph on
// those nodes bit for bit, whatever the thread count.
TEST(FirstOrderGraph, BoundedGraphsAreThePairByPairGraphOnTheirNodes) {
  const GraphParams defaults;
  const CorrespondenceSet sampled_set = rigidProblem(2500, 500, 11);
  std::vector<char> sample(2500, 0);
  for (int k = 0; k < 1000; ++k) sample[k * 5 / 2] = 1;
  const CompatibilityGraph expected_sampled = keepNodes(pairByPairFirstOrder(sampled_set, defaults), sample);

  const CorrespondenceSet dense_set = rigidProblem(2000, 300, 5);
  const CompatibilityGraph dense_full = pairByPairFirstOrder(dense_set, defaults);
  std::vector<double> degree(2000);
  for (int i = 0; i < 2000; ++i) degree[i] = dense_full.degree(i);
  const CompatibilityGraph expected_reduced = keepNodes(dense_full, strongestNodes(degree, 200));
  ASSERT_GT(expected_reduced.numEdges(), 10000u);

  for (const int threads : {1, 2, 3}) {
    GraphParams params;
    params.max_correspondences = 1000;
    const FirstOrderGraph sampled = buildFirstOrderGraph(sampled_set, params, threads);
    ASSERT_TRUE(sampled.sampled);
    EXPECT_EQ(sampled.graph.offsets, expected_sampled.offsets) << threads << " threads";
    EXPECT_EQ(sampled.graph.neighbours, expected_sampled.neighbours) << threads << " threads";
    EXPECT_EQ(sampled.graph.weights, expected_sampled.weights) << threads << " threads";

    params = GraphParams();
    params.max_edges = 20000;  // keeps sqrt(40 000) = 200 nodes
    const FirstOrderGraph reduced = buildFirstOrderGraph(dense_set, params, threads);
    ASSERT_TRUE(reduced.reduced);
    EXPECT_EQ(reduced.graph.offsets, expected_reduced.offsets) << threads << " threads";
    EXPECT_EQ(reduced.graph.neighbours, expected_reduced.neighbours) << threads << " threads";
    EXPECT_EQ(reduced.graph.weights, expected_reduced.weights) << threads << " threads";
  }
}

// The second-order budget applied to the pass's rows gives the graph boundSecondOrderWork makes of the
// whole first-order graph, bit for bit, with the same count of kept nodes and removed edges: on the whole
// set, on an evenly spaced sample, and after the max_edges reduction; and nothing changes within budget.
TEST(FirstOrderGraph, TheSecondOrderBudgetOnTheRowsIsBoundSecondOrderWork) {
  struct Case {
    int size, inliers;
    std::size_t max_correspondences, max_edges;
  };
  for (const Case& test_case :
       {Case{900, 450, 50000, 4000000}, Case{1200, 500, 1000, 4000000}, Case{900, 450, 50000, 60000}}) {
    GraphParams params;
    params.max_correspondences = test_case.max_correspondences;
    params.max_edges = test_case.max_edges;
    const CorrespondenceSet c = rigidProblem(test_case.size, test_case.inliers, 13);
    const FirstOrderGraph whole = buildFirstOrderGraph(c, params, 1);
    ASSERT_EQ(whole.sampled, test_case.max_correspondences < std::size_t(test_case.size));
    ASSERT_EQ(whole.reduced, test_case.max_edges < 4000000u);
    const double work = secondOrderWork(whole.graph);
    const double budget = work / 20.0;
    const BoundedGraph expected = boundSecondOrderWork(whole.graph, budget);
    ASSERT_TRUE(expected.reduced);
    ASSERT_GT(expected.graph.numEdges(), 1000u);
    for (const int threads : {1, 2, 3}) {
      const FirstOrderGraph bounded = buildFirstOrderGraph(c, params, threads, nullptr, budget);
      ASSERT_TRUE(bounded.second_order_bounded) << threads << " threads";
      EXPECT_EQ(bounded.sampled, whole.sampled);
      EXPECT_EQ(bounded.reduced, whole.reduced);
      EXPECT_EQ(bounded.second_order_kept_nodes, expected.kept_nodes) << threads << " threads";
      EXPECT_EQ(bounded.second_order_removed_edges, expected.removed_edges) << threads << " threads";
      EXPECT_EQ(bounded.graph.offsets, expected.graph.offsets) << threads << " threads";
      EXPECT_EQ(bounded.graph.neighbours, expected.graph.neighbours) << threads << " threads";
      EXPECT_EQ(bounded.graph.weights, expected.graph.weights) << threads << " threads";
      EXPECT_LE(secondOrderWork(bounded.graph), budget);

      const FirstOrderGraph within = buildFirstOrderGraph(c, params, threads, nullptr, work);
      EXPECT_FALSE(within.second_order_bounded);
      EXPECT_EQ(within.graph.neighbours, whole.graph.neighbours) << threads << " threads";
      EXPECT_EQ(within.graph.weights, whole.graph.weights) << threads << " threads";
    }
  }
}

// 200 exact inliers make a complete graph of 19900 edges.
TEST(FirstOrderGraph, MaxEdgesBound) {
  const CorrespondenceSet c = rigidProblem(200, 200, 3);
  GraphParams params;
  params.max_edges = 19900;  // exactly fits: not reduced
  FirstOrderGraph fog = buildFirstOrderGraph(c, params, 2);
  EXPECT_FALSE(fog.reduced);
  EXPECT_EQ(fog.graph.numEdges(), 19900u);

  params.max_edges = 19899;  // one too few: reduced
  EXPECT_TRUE(buildFirstOrderGraph(c, params, 2).reduced);

  params.max_edges = 1000;
  fog = buildFirstOrderGraph(c, params, 2);
  expectValidGraph(fog.graph);
  EXPECT_TRUE(fog.reduced);
  EXPECT_LE(fog.graph.numEdges(), 1000u);
  EXPECT_EQ(fog.graph.num_nodes, 200);  // node ids stay correspondence indices
  // sqrt(2 * 1000) = 44 nodes kept; all have the same degree (199), so ties keep nodes 0..43 and
  // they form a complete graph of 44 * 43 / 2 = 946 edges.
  EXPECT_EQ(fog.reduced_to, 44u);
  EXPECT_EQ(fog.graph.numEdges(), 946u);
  for (int i = 0; i < 200; ++i) EXPECT_EQ(fog.graph.degree(i), i < 44 ? 43 : 0) << "node " << i;
}

TEST(FirstOrderGraph, MaxEdgesKeepsTheNodesOfHighestDegree) {
  // 300 exact inliers (44 850 edges among them) and 1700 outliers compatible with a few % of the others.
  const CorrespondenceSet c = rigidProblem(2000, 300, 5);
  GraphParams params;
  params.max_edges = 20000;  // keeps sqrt(40 000) = 200 nodes: inliers only, all compatible with each other
  const FirstOrderGraph fog = buildFirstOrderGraph(c, params, 2);
  expectValidGraph(fog.graph);
  ASSERT_TRUE(fog.reduced);
  EXPECT_FALSE(fog.sampled);
  EXPECT_GE(fog.compatible_pairs, 300u * 299u / 2u);  // every pair counted, past max_edges
  EXPECT_EQ(fog.reduced_to, 200u);
  EXPECT_EQ(fog.graph.numEdges(), 200u * 199u / 2u);
  for (int i = 0; i < fog.graph.num_nodes; ++i) {
    if (fog.graph.degree(i) > 0) {
      EXPECT_LT(i, 300) << "outlier " << i << " kept";
    }
  }
}

TEST(FirstOrderGraph, MaxCorrespondencesBuildsOnAnEvenlySpacedSubset) {
  const CorrespondenceSet c = rigidProblem(2500, 500, 11);
  GraphParams params;
  params.max_correspondences = 1000;
  const FirstOrderGraph fog = buildFirstOrderGraph(c, params, 2);
  expectValidGraph(fog.graph);
  ASSERT_TRUE(fog.sampled);
  EXPECT_FALSE(fog.reduced);
  EXPECT_EQ(fog.sampled_to, 1000u);
  ASSERT_EQ(fog.graph.num_nodes, 2500);  // node ids stay correspondence indices

  // The same graph as one built on those correspondences alone: every 2.5th, 0, 2, 5, 7, 10, ...
  std::vector<int> subset;
  for (int k = 0; k < 1000; ++k) subset.push_back(k * 5 / 2);
  CorrespondenceSet sub;
  sub.source_points.resize(3, 1000);
  sub.target_points.resize(3, 1000);
  for (int k = 0; k < 1000; ++k) {
    sub.source_points.col(k) = c.source_points.col(subset[k]);
    sub.target_points.col(k) = c.target_points.col(subset[k]);
  }
  params.max_correspondences = 0;  // no bound
  const FirstOrderGraph reference = buildFirstOrderGraph(sub, params, 1);
  EXPECT_FALSE(reference.sampled);
  EXPECT_EQ(fog.graph.numEdges(), reference.graph.numEdges());
  EXPECT_EQ(fog.compatible_pairs, reference.graph.numEdges());
  EXPECT_GE(fog.graph.numEdges(), 200u * 199u / 2u);  // the 200 inliers among them
  std::vector<char> in_subset(2500, 0);
  for (int node : subset) in_subset[node] = 1;
  for (int i = 0; i < 2500; ++i) {
    if (!in_subset[i]) {
      EXPECT_EQ(fog.graph.degree(i), 0) << "node " << i;
    }
  }
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(fog.graph.degree(subset[k]), reference.graph.degree(k)) << "node " << subset[k];
    for (auto p = reference.graph.offsets[k]; p < reference.graph.offsets[k + 1]; ++p) {
      // Centred on another centroid, the floats differ in their last bits: the weights by ~1e-6.
      EXPECT_NEAR(fog.graph.weight(subset[k], subset[reference.graph.neighbours[p]]),
                  reference.graph.weights[p], 1e-5);
    }
  }
}

TEST(FirstOrderGraph, BoundsActTheSameForOneAndTwoThreads) {
  const CorrespondenceSet c = rigidProblem(2500, 500, 13);
  GraphParams params;
  params.max_correspondences = 1000;
  params.max_edges = 5000;
  const FirstOrderGraph one = buildFirstOrderGraph(c, params, 1);
  const FirstOrderGraph two = buildFirstOrderGraph(c, params, 2);
  ASSERT_TRUE(one.sampled && one.reduced);
  EXPECT_EQ(one.compatible_pairs, two.compatible_pairs);
  EXPECT_EQ(one.reduced_to, two.reduced_to);
  EXPECT_EQ(one.graph.neighbours, two.graph.neighbours);
  EXPECT_EQ(one.graph.weights, two.graph.weights);
}

TEST(FirstOrderGraph, RaisedStopFlagLeavesNoEdges) {
  const StopFlag stop{true};
  const FirstOrderGraph fog = buildFirstOrderGraph(rigidProblem(300, 210, 7), GraphParams{}, 2, &stop);
  EXPECT_TRUE(fog.cancelled);
  EXPECT_EQ(fog.graph.num_nodes, 300);
  EXPECT_EQ(fog.graph.numEdges(), 0u);
}

}  // namespace
}  // namespace mac_registration
