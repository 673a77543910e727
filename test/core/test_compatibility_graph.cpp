// First- and second-order compatibility graphs (paper Eq. 1-4) on hand-made inputs.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "mac_registration/core/compatibility_graph.hpp"
#include "mac_registration/core/graph_bounds.hpp"

namespace mac_registration {
namespace {

// Offsets consistent, lists strictly ascending, no self loops, every edge stored both ways with one weight.
void expectValidGraph(const CompatibilityGraph& g) {
  ASSERT_EQ(g.offsets.size(), static_cast<std::size_t>(g.num_nodes) + 1);
  ASSERT_EQ(g.offsets.front(), 0);
  ASSERT_EQ(static_cast<std::size_t>(g.offsets.back()), g.neighbours.size());
  ASSERT_EQ(g.neighbours.size(), g.weights.size());
  for (int i = 0; i < g.num_nodes; ++i) {
    for (auto p = g.offsets[i]; p < g.offsets[i + 1]; ++p) {
      const int j = g.neighbours[p];
      EXPECT_NE(j, i);
      if (p > g.offsets[i]) {
        EXPECT_LT(g.neighbours[p - 1], j) << "node " << i;
      }
      EXPECT_EQ(g.weight(j, i), g.weights[p]) << "edge " << i << "-" << j << " is not symmetric";
    }
  }
}

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

// Two triangles sharing edge 1-2 (0-1-2 and 1-2-3) plus a pendant edge 3-4 in no triangle.
CompatibilityGraph twoTrianglesAndPendant() {
  return graphFromUpperRows(5,
                            {{{1, 0.5f}, {2, 0.8f}}, {{2, 0.9f}, {3, 0.6f}}, {{3, 0.7f}}, {{4, 1.0f}}, {}});
}

TEST(CompatibilityGraph, FromUpperRowsAndWeightLookup) {
  const CompatibilityGraph g = twoTrianglesAndPendant();
  expectValidGraph(g);
  EXPECT_EQ(g.numEdges(), 6u);
  EXPECT_EQ(g.degree(0), 2);
  EXPECT_EQ(g.degree(2), 3);
  EXPECT_EQ(g.degree(4), 1);
  EXPECT_EQ(g.neighbours, (std::vector<int>{1, 2, 0, 2, 3, 0, 1, 3, 1, 2, 4, 3}));
  EXPECT_FLOAT_EQ(g.weight(1, 3), 0.6f);
  EXPECT_FLOAT_EQ(g.weight(3, 1), 0.6f);
  EXPECT_FLOAT_EQ(g.weight(4, 3), 1.0f);
  EXPECT_EQ(g.weight(0, 3), 0.0f);
  EXPECT_EQ(g.weight(0, 4), 0.0f);
  EXPECT_EQ(g.weight(2, 2), 0.0f);
}

// w_ij = S_ij * sum_k S_ik S_jk, computed by hand. Float sums of a few products: 1e-6.
TEST(SecondOrderGraph, WeightsByHand) {
  const CompatibilityGraph sog = buildSecondOrderGraph(twoTrianglesAndPendant(), 1);
  expectValidGraph(sog);
  EXPECT_EQ(sog.numEdges(), 5u);
  EXPECT_NEAR(sog.weight(0, 1), 0.5 * (0.8 * 0.9), 1e-6);              // k = 2
  EXPECT_NEAR(sog.weight(0, 2), 0.8 * (0.5 * 0.9), 1e-6);              // k = 1
  EXPECT_NEAR(sog.weight(1, 2), 0.9 * (0.5 * 0.8 + 0.6 * 0.7), 1e-6);  // k = 0 and 3
  EXPECT_NEAR(sog.weight(1, 3), 0.6 * (0.9 * 0.7), 1e-6);              // k = 2
  EXPECT_NEAR(sog.weight(2, 3), 0.7 * (0.9 * 0.6), 1e-6);              // k = 1
  EXPECT_EQ(sog.weight(3, 4), 0.0f);                                   // in no triangle: removed
  EXPECT_EQ(sog.degree(4), 0);
  EXPECT_DOUBLE_EQ(secondOrderWork(twoTrianglesAndPendant()), 3 + 3 + 3 + 3 + 3 + 1);  // deg(j) per edge i<j
}

// A random graph with weights in (0.5, 1]: each pair an edge with probability `density`.
CompatibilityGraph randomWeightedGraph(int n, double density, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::vector<UpperEdge>> rows(n);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (u(rng) < density) rows[i].push_back({j, static_cast<float>(0.5 + 0.5 * u(rng))});
    }
  }
  return graphFromUpperRows(n, rows);
}

// Eq. 4 straight from a dense matrix: for every edge i < j, the float sum over k = 0, 1, ... of
// S_ik * S_jk (every k, adding the zeros of non-neighbours), times S_ij; edges whose sum is 0 dropped.
CompatibilityGraph denseSecondOrder(const CompatibilityGraph& fog) {
  const int n = fog.num_nodes;
  std::vector<float> s(std::size_t(n) * n, 0.0f);
  for (int i = 0; i < n; ++i) {
    for (auto p = fog.offsets[i]; p < fog.offsets[i + 1]; ++p)
      s[std::size_t(i) * n + fog.neighbours[p]] = fog.weights[p];
  }
  std::vector<std::vector<UpperEdge>> rows(n);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const float s_ij = s[std::size_t(i) * n + j];
      if (s_ij == 0.0f) continue;
      float common = 0.0f;
      for (int k = 0; k < n; ++k) common += s[std::size_t(i) * n + k] * s[std::size_t(j) * n + k];
      if (common > 0.0f) rows[i].push_back({j, s_ij * common});
    }
  }
  return graphFromUpperRows(n, rows);
}

// The sums run several edges side by side on long lists and one by one on short ones: either way each must
// be the plain sum in ascending order, bit for bit, whatever the thread count. Densities from a few
// neighbours (short lists, edges in no triangle) to 60 % (long lists, every path of the lanes).
TEST(SecondOrderGraph, BitIdenticalToTheDenseSum) {
  for (const double density : {0.01, 0.05, 0.3, 0.6}) {
    const CompatibilityGraph fog = randomWeightedGraph(400, density, 11);
    const CompatibilityGraph expected = denseSecondOrder(fog);
    for (const int threads : {1, 2}) {
      const CompatibilityGraph sog = buildSecondOrderGraph(fog, threads);
      expectValidGraph(sog);
      EXPECT_EQ(sog.offsets, expected.offsets) << "density " << density << ", " << threads << " threads";
      EXPECT_EQ(sog.neighbours, expected.neighbours)
          << "density " << density << ", " << threads << " threads";
      EXPECT_EQ(sog.weights, expected.weights) << "density " << density << ", " << threads << " threads";
    }
  }
}

// The counted estimate straight from a dense matrix: c_ij common neighbours counted one k at a time, m_i
// the mean of row i's weights summed in ascending order in double, w_ij = S_ij * float(c_ij m_i m_j).
CompatibilityGraph denseCountedSecondOrder(const CompatibilityGraph& fog) {
  const int n = fog.num_nodes;
  std::vector<float> s(std::size_t(n) * n, 0.0f);
  std::vector<double> mean(n, 0.0);
  for (int i = 0; i < n; ++i) {
    for (auto p = fog.offsets[i]; p < fog.offsets[i + 1]; ++p) {
      s[std::size_t(i) * n + fog.neighbours[p]] = fog.weights[p];
      mean[i] += fog.weights[p];
    }
    if (fog.degree(i) > 0) mean[i] /= fog.degree(i);
  }
  std::vector<std::vector<UpperEdge>> rows(n);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const float s_ij = s[std::size_t(i) * n + j];
      if (s_ij == 0.0f) continue;
      int shared = 0;
      for (int k = 0; k < n; ++k)
        shared += s[std::size_t(i) * n + k] != 0.0f && s[std::size_t(j) * n + k] != 0.0f;
      if (shared > 0) rows[i].push_back({j, s_ij * static_cast<float>(shared * mean[i] * mean[j])});
    }
  }
  return graphFromUpperRows(n, rows);
}

// Weights in [t, 1], as the first-order graph's are in [t_cmp, 1].
CompatibilityGraph randomGraphWithWeightsFrom(int n, double density, float t, unsigned seed) {
  CompatibilityGraph g = randomWeightedGraph(n, density, seed);
  for (float& w : g.weights) w = t + (1.0f - t) * (w - 0.5f) * 2.0f;  // 0.5 + 0.5 u -> t + (1 - t) u
  return g;
}

// The popcounts over bit rows (AVX-512 or portable, with isolated nodes left out of the rows and rows of
// 1 to several 512-bit blocks) must count exactly the common neighbours; the estimate is the counted
// formula bit for bit, on the exact graph's edges, within t^2 of the exact weights, whatever the threads.
TEST(SecondOrderGraph, CountedWeightsMatchTheDenseCount) {
  const float t = 0.99f;
  for (const int n : {60, 700, 1100}) {
    for (const double density : {0.02, 0.3}) {
      CompatibilityGraph fog = randomGraphWithWeightsFrom(n, density, t, 5);
      fog = keepNodes(fog, std::vector<char>(n, 1));
      std::vector<char> keep(n, 1);
      for (int i = 0; i < n; i += 7) keep[i] = 0;  // isolated nodes between active ones
      fog = keepNodes(fog, keep);
      const CompatibilityGraph expected = denseCountedSecondOrder(fog);
      const CompatibilityGraph exact = buildSecondOrderGraph(fog, 1);
      for (const int threads : {1, 2}) {
        const CompatibilityGraph counted = buildCountedSecondOrderGraph(fog, threads);
        const std::string where = "n " + std::to_string(n) + ", density " + std::to_string(density) + ", " +
                                  std::to_string(threads) + " threads";
        expectValidGraph(counted);
        EXPECT_EQ(counted.offsets, expected.offsets) << where;
        EXPECT_EQ(counted.neighbours, expected.neighbours) << where;
        EXPECT_EQ(counted.weights, expected.weights) << where;
        ASSERT_EQ(counted.neighbours, exact.neighbours) << where;
        for (std::size_t q = 0; q < exact.weights.size(); ++q) {
          EXPECT_GE(counted.weights[q], exact.weights[q] * t * t * 0.9999f) << where;
          EXPECT_LE(counted.weights[q] * t * t, exact.weights[q] * 1.0001f) << where;
        }
      }
    }
  }
}

void expectSameGraph(const CompatibilityGraph& a, const CompatibilityGraph& b, const std::string& where) {
  EXPECT_EQ(a.num_nodes, b.num_nodes) << where;
  EXPECT_EQ(a.offsets, b.offsets) << where;
  EXPECT_EQ(a.neighbours, b.neighbours) << where;
  EXPECT_EQ(a.weights, b.weights) << where;
}

// Sparse first-order graphs keep the exact sums; above dense_mean_degree the counts take over, and 0
// turns them off. Either way the graph is the second-order graph cut by pruneDenseGraph, bit for bit,
// though the counted one is cut before it is built.
TEST(SecondOrderGraph, CountedOnlyAboveTheDenseMeanDegreeAndCutAsAfterwards) {
  const CompatibilityGraph sparse = randomGraphWithWeightsFrom(1500, 0.01, 0.99f, 2);  // mean degree ~15
  const SecondOrderOutcome exact = prunedSecondOrderGraph(sparse, 50.0, 2);
  EXPECT_FALSE(exact.counted);
  EXPECT_FALSE(exact.pruned.reduced);
  expectSameGraph(exact.pruned.graph, buildSecondOrderGraph(sparse, 1), "sparse");

  for (const double density : {0.05, 0.1, 0.3}) {
    const std::string where = "density " + std::to_string(density);
    const CompatibilityGraph dense = randomGraphWithWeightsFrom(1500, density, 0.99f, 2);  // degree 75-450
    const SecondOrderOutcome counted = prunedSecondOrderGraph(dense, 50.0, 2);
    const BoundedGraph afterwards = pruneDenseGraph(buildCountedSecondOrderGraph(dense, 1), 50.0);
    EXPECT_TRUE(counted.counted) << where;
    ASSERT_TRUE(afterwards.reduced) << where;
    EXPECT_TRUE(counted.pruned.reduced) << where;
    EXPECT_GT(afterwards.removed_edges, 0u) << where;
    EXPECT_EQ(counted.pruned.removed_edges, afterwards.removed_edges) << where;
    expectSameGraph(counted.pruned.graph, afterwards.graph, where);
  }
  const CompatibilityGraph dense = randomGraphWithWeightsFrom(1500, 0.1, 0.99f, 2);
  const SecondOrderOutcome off = prunedSecondOrderGraph(dense, 0.0, 2);
  EXPECT_FALSE(off.counted);
  EXPECT_FALSE(off.pruned.reduced);
  expectSameGraph(off.pruned.graph, buildSecondOrderGraph(dense, 1), "dense_mean_degree 0");
}

// The counted sums' graph and its Otsu cut, built without the graph, are what building it and cutting it
// give, bit for bit, on any thread count; some edges are in no triangle (a zero sum) and some nodes isolated.
TEST(SecondOrderGraph, GraphAndCutOfTheSumsAreTheSameOnAnyThreadCount) {
  for (const double density : {0.01, 0.1}) {
    CompatibilityGraph fog = randomGraphWithWeightsFrom(1200, density, 0.99f, 3);
    std::vector<char> keep(1200, 1);
    for (int i = 0; i < 1200; i += 11) keep[i] = 0;
    fog = keepNodes(fog, keep);
    const std::vector<float> common = countedCommonSums(fog, 1);
    ASSERT_GT(std::count(common.begin(), common.end(), 0.0f), 0);
    const CompatibilityGraph all = triangleEdgesFromSums(fog, common, 0.0f, 1);
    const std::string where = "density " + std::to_string(density);
    expectValidGraph(all);
    ASSERT_GT(all.numEdges(), 100u) << where;
    const float cut = otsuEdgeThreshold(all);
    const CompatibilityGraph heavy = withoutWeakEdges(all, cut);
    ASSERT_LT(heavy.numEdges(), all.numEdges()) << where;
    for (const int threads : {1, 2, 3}) {
      const std::string with = where + ", " + std::to_string(threads) + " threads";
      expectSameGraph(triangleEdgesFromSums(fog, common, 0.0f, threads), all, with);
      expectSameGraph(triangleEdgesFromSums(fog, common, cut, threads), heavy, with);
      std::size_t edges = 0;
      EXPECT_EQ(otsuThresholdOfSums(fog, common, edges, threads), cut) << with;
      EXPECT_EQ(edges, all.numEdges()) << with;
    }
  }
}

TEST(CompatibilityGraph, KeepNodes) {
  const CompatibilityGraph kept = keepNodes(twoTrianglesAndPendant(), {0, 1, 1, 1, 0});
  expectValidGraph(kept);
  EXPECT_EQ(kept.num_nodes, 5);
  EXPECT_EQ(kept.numEdges(), 3u);
  EXPECT_FLOAT_EQ(kept.weight(1, 2), 0.9f);
  EXPECT_FLOAT_EQ(kept.weight(1, 3), 0.6f);
  EXPECT_FLOAT_EQ(kept.weight(2, 3), 0.7f);
  EXPECT_EQ(kept.degree(0), 0);
  EXPECT_EQ(kept.degree(4), 0);
}

// keepNodes and withoutWeakEdges filter the lists in place; rebuilt from the upper rows of the edges they
// keep, the graphs must be the same, list for list and weight for weight. So must the work of the kept
// graph counted without building it.
TEST(CompatibilityGraph, FiltersMatchTheGraphRebuiltFromTheKeptEdges) {
  const CompatibilityGraph g = randomWeightedGraph(300, 0.1, 3);
  std::mt19937 rng(9);
  std::vector<char> keep(g.num_nodes);
  for (auto& k : keep) k = rng() % 3 != 0;
  const float threshold = 0.8f;
  std::vector<std::vector<UpperEdge>> kept_rows(g.num_nodes), heavy_rows(g.num_nodes);
  for (int i = 0; i < g.num_nodes; ++i) {
    for (auto p = g.offsets[i]; p < g.offsets[i + 1]; ++p) {
      const int j = g.neighbours[p];
      if (j < i) continue;
      if (keep[i] && keep[j]) kept_rows[i].push_back({j, g.weights[p]});
      if (g.weights[p] >= threshold) heavy_rows[i].push_back({j, g.weights[p]});
    }
  }
  const CompatibilityGraph kept = keepNodes(g, keep),
                           expected_kept = graphFromUpperRows(g.num_nodes, kept_rows);
  EXPECT_EQ(kept.offsets, expected_kept.offsets);
  EXPECT_EQ(kept.neighbours, expected_kept.neighbours);
  EXPECT_EQ(kept.weights, expected_kept.weights);
  EXPECT_LT(kept.numEdges(), g.numEdges());
  const CompatibilityGraph heavy = withoutWeakEdges(g, threshold);
  const CompatibilityGraph expected_heavy = graphFromUpperRows(g.num_nodes, heavy_rows);
  EXPECT_EQ(heavy.offsets, expected_heavy.offsets);
  EXPECT_EQ(heavy.neighbours, expected_heavy.neighbours);
  EXPECT_EQ(heavy.weights, expected_heavy.weights);
  EXPECT_LT(heavy.numEdges(), g.numEdges());
  EXPECT_DOUBLE_EQ(secondOrderWorkOfNodes(g, keep), secondOrderWork(expected_kept));
  EXPECT_DOUBLE_EQ(secondOrderWorkOfNodes(g, std::vector<char>(g.num_nodes, 1)), secondOrderWork(g));
  // On any thread count: the same graphs, and the same work, or +infinity past a limit below it.
  const double work = secondOrderWork(expected_kept);
  for (const int threads : {1, 2, 3}) {
    const CompatibilityGraph kept_t = keepNodes(g, keep, threads);
    EXPECT_EQ(kept_t.offsets, expected_kept.offsets) << threads;
    EXPECT_EQ(kept_t.neighbours, expected_kept.neighbours) << threads;
    EXPECT_EQ(kept_t.weights, expected_kept.weights) << threads;
    const CompatibilityGraph heavy_t = withoutWeakEdges(g, threshold, threads);
    EXPECT_EQ(heavy_t.neighbours, expected_heavy.neighbours) << threads;
    EXPECT_EQ(heavy_t.weights, expected_heavy.weights) << threads;
    EXPECT_EQ(secondOrderWorkOfNodes(g, keep, work, threads), work) << threads;
    EXPECT_EQ(secondOrderWorkOfNodes(g, keep, work - 1.0, threads), std::numeric_limits<double>::infinity())
        << threads;
    EXPECT_EQ(secondOrderWorkOfNodes(g, keep, 0.0, threads), std::numeric_limits<double>::infinity())
        << threads;
  }
}

TEST(CompatibilityGraph, StrongestNodes) {
  EXPECT_EQ(strongestNodes({1.0, 3.0, 3.0, 2.0}, 2), (std::vector<char>{0, 1, 1, 0}));
  EXPECT_EQ(strongestNodes({1.0, 3.0, 3.0, 2.0}, 3), (std::vector<char>{0, 1, 1, 1}));
  EXPECT_EQ(strongestNodes({2.0, 2.0, 2.0}, 1), (std::vector<char>{1, 0, 0}));  // ties to the lower index
  EXPECT_EQ(strongestNodes({0.5, 1.0}, 10), (std::vector<char>{1, 1}));
  EXPECT_EQ(strongestNodes({0.5, 1.0}, 0), (std::vector<char>{0, 0}));
}

TEST(CompatibilityGraph, NodeStrength) {
  const std::vector<double> s = nodeStrength(twoTrianglesAndPendant());
  ASSERT_EQ(s.size(), 5u);
  // Weights are floats: 1e-6.
  EXPECT_NEAR(s[0], 0.5 + 0.8, 1e-6);
  EXPECT_NEAR(s[1], 0.5 + 0.9 + 0.6, 1e-6);
  EXPECT_NEAR(s[2], 0.8 + 0.9 + 0.7, 1e-6);
  EXPECT_NEAR(s[3], 0.6 + 0.7 + 1.0, 1e-6);
  EXPECT_NEAR(s[4], 1.0, 1e-6);
}

// Core numbers by repeated peeling: node v is in the k-core while it keeps >= k neighbours in it.
std::vector<int> bruteForceCores(const CompatibilityGraph& g) {
  std::vector<int> core(g.num_nodes, 0);
  for (int k = 1;; ++k) {
    std::vector<char> alive(g.num_nodes, 1);
    for (bool changed = true; changed;) {
      changed = false;
      for (int v = 0; v < g.num_nodes; ++v) {
        if (!alive[v]) continue;
        int degree = 0;
        for (auto p = g.offsets[v]; p < g.offsets[v + 1]; ++p) degree += alive[g.neighbours[p]];
        if (degree < k) alive[v] = 0, changed = true;
      }
    }
    bool any = false;
    for (int v = 0; v < g.num_nodes; ++v) {
      if (alive[v]) core[v] = k, any = true;
    }
    if (!any) return core;
  }
}

TEST(CompatibilityGraph, CoreNumbers) {
  // By hand: the two triangles make a 2-core {0,1,2,3}; the pendant node 4 has core 1.
  EXPECT_EQ(coreNumbers(twoTrianglesAndPendant()), (std::vector<int>{2, 2, 2, 2, 1}));
  // K4 (core 3) with a triangle on node 3 (core 2) and an isolated node (core 0).
  const CompatibilityGraph k4 = graphFromUpperRows(
      7, {{{1, 1}, {2, 1}, {3, 1}}, {{2, 1}, {3, 1}}, {{3, 1}}, {{4, 1}, {5, 1}}, {{5, 1}}, {}, {}});
  EXPECT_EQ(coreNumbers(k4), (std::vector<int>{3, 3, 3, 3, 2, 2, 0}));
  // Random graphs (fixed seed) against the peeling definition.
  std::mt19937 rng(17);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 30;
    std::bernoulli_distribution edge(0.05 + 0.02 * trial);
    std::vector<std::vector<UpperEdge>> rows(n);
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        if (edge(rng)) rows[i].push_back({j, 1.0f});
      }
    }
    const CompatibilityGraph g = graphFromUpperRows(n, rows);
    EXPECT_EQ(coreNumbers(g), bruteForceCores(g)) << "trial " << trial;
  }
}

TEST(CompatibilityGraph, OtsuThresholdSeparatesLightFromHeavyEdges) {
  // Light edges 0.1, 0.1, 0.12 and heavy ones 0.9, 0.95, 1.0: the cut falls between 0.12 and 0.9.
  const CompatibilityGraph g = graphFromUpperRows(
      6, {{{1, 0.1f}, {2, 0.9f}}, {{2, 0.12f}, {3, 0.95f}}, {{3, 0.1f}}, {{4, 1.0f}}, {}, {}});
  const float threshold = otsuEdgeThreshold(g);
  EXPECT_GT(threshold, 0.12f);
  EXPECT_LE(threshold, 0.9f);
  const CompatibilityGraph heavy = withoutWeakEdges(g, threshold);
  expectValidGraph(heavy);
  EXPECT_EQ(heavy.numEdges(), 3u);
  EXPECT_EQ(heavy.weight(0, 2), 0.9f);
  EXPECT_EQ(heavy.weight(1, 3), 0.95f);
  EXPECT_EQ(heavy.weight(3, 4), 1.0f);
  // An edge exactly at the threshold stays; equal weights give that weight and keep everything.
  EXPECT_EQ(withoutWeakEdges(g, 0.9f).numEdges(), 3u);
  const CompatibilityGraph flat = graphFromUpperRows(3, {{{1, 0.5f}, {2, 0.5f}}, {{2, 0.5f}}, {}});
  EXPECT_EQ(otsuEdgeThreshold(flat), 0.5f);
  EXPECT_EQ(withoutWeakEdges(flat, otsuEdgeThreshold(flat)).numEdges(), 3u);
  EXPECT_EQ(otsuEdgeThreshold(graphFromUpperRows(2, {{}, {}})), 0.0f);
}

// Otsu's cut as defined: a 256-bin histogram of every stored weight (each edge twice) and the bin that
// maximises the between-class variance. The graph's cut counts each edge once and must agree exactly.
float otsuOverBothDirections(const CompatibilityGraph& g) {
  const auto [lo, hi] = std::minmax_element(g.weights.begin(), g.weights.end());
  const double low = *lo, span = double(*hi) - low;
  if (!(span > 0.0)) return *lo;
  std::vector<double> count(256, 0.0);
  for (float w : g.weights) count[std::min(255, int((w - low) / span * 256))] += 1.0;
  double sum_all = 0.0, below = 0.0, sum_below = 0.0, best = -1.0;
  for (int b = 0; b < 256; ++b) sum_all += b * count[b];
  int best_bin = 0;
  for (int b = 0; b < 255; ++b) {
    below += count[b];
    sum_below += b * count[b];
    const double above = double(g.weights.size()) - below;
    if (below == 0.0 || above == 0.0) continue;
    const double d = sum_below / below - (sum_all - sum_below) / above;
    if (below * above * d * d > best) best = below * above * d * d, best_bin = b;
  }
  return float(low + span * (best_bin + 1) / 256);
}

TEST(CompatibilityGraph, OtsuThresholdAndWorkMatchTheirDefinitions) {
  for (const unsigned seed : {1u, 2u, 3u, 4u}) {
    const CompatibilityGraph g = buildSecondOrderGraph(randomWeightedGraph(300, 0.05 * seed, seed), 1);
    EXPECT_EQ(otsuEdgeThreshold(g), otsuOverBothDirections(g)) << "seed " << seed;
    double work = 0.0;
    for (int i = 0; i < g.num_nodes; ++i) {
      for (auto p = g.offsets[i]; p < g.offsets[i + 1]; ++p)
        work += g.neighbours[p] > i ? g.degree(g.neighbours[p]) : 0;
    }
    EXPECT_EQ(secondOrderWork(g), work) << "seed " << seed;
  }
}

}  // namespace
}  // namespace mac_registration
