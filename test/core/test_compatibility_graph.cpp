// The second-order graph (paper Eq. 4), exact and counted, and the graph operations, on hand-made inputs.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "compatibility_graph.hpp"
#include "graph_bounds.hpp"
#include "graph_builders.hpp"
#include "graph_test_support.hpp"

namespace mac_registration {
namespace {

using test::expectValidGraph;

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
  const SecondOrderOutcome exact = prunedSecondOrderGraph(upperRowsOf(sparse), 50.0, 2);
  EXPECT_FALSE(exact.counted);
  EXPECT_FALSE(exact.pruned.reduced);
  expectSameGraph(exact.pruned.graph, buildSecondOrderGraph(sparse, 1), "sparse");

  for (const double density : {0.05, 0.1, 0.3}) {
    const std::string where = "density " + std::to_string(density);
    const CompatibilityGraph dense = randomGraphWithWeightsFrom(1500, density, 0.99f, 2);  // degree 75-450
    const SecondOrderOutcome counted = prunedSecondOrderGraph(upperRowsOf(dense), 50.0, 2);
    const BoundedGraph afterwards = pruneDenseGraph(buildCountedSecondOrderGraph(dense, 1), 50.0);
    EXPECT_TRUE(counted.counted) << where;
    ASSERT_TRUE(afterwards.reduced) << where;
    EXPECT_TRUE(counted.pruned.reduced) << where;
    EXPECT_GT(afterwards.removed_edges, 0u) << where;
    EXPECT_EQ(counted.pruned.removed_edges, afterwards.removed_edges) << where;
    expectSameGraph(counted.pruned.graph, afterwards.graph, where);
  }
  const CompatibilityGraph dense = randomGraphWithWeightsFrom(1500, 0.1, 0.99f, 2);
  const SecondOrderOutcome off = prunedSecondOrderGraph(upperRowsOf(dense), 0.0, 2);
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
    const UpperRows rows = upperRowsOf(fog);
    const EdgeSums common = countedCommonSums(rows, 1);
    ASSERT_GT(std::count(common.begin(), common.end(), 0.0f), 0);
    const CompatibilityGraph all = triangleEdgesFromSums(rows, common, 0.0f, 1);
    const std::string where = "density " + std::to_string(density);
    expectValidGraph(all);
    ASSERT_GT(all.numEdges(), 100u) << where;
    const float cut = otsuEdgeThreshold(all);
    const CompatibilityGraph heavy = withoutWeakEdges(all, cut);
    ASSERT_LT(heavy.numEdges(), all.numEdges()) << where;
    for (const int threads : {1, 2, 3}) {
      const std::string with = where + ", " + std::to_string(threads) + " threads";
      expectSameGraph(triangleEdgesFromSums(rows, common, 0.0f, threads), all, with);
      expectSameGraph(triangleEdgesFromSums(rows, common, cut, threads), heavy, with);
      std::size_t edges = 0;
      EXPECT_EQ(otsuThresholdOfSums(rows, common, edges, threads), cut) << with;
      EXPECT_EQ(edges, all.numEdges()) << with;
    }
  }
}

// Frees buffers of `floats` NaNs twice over, so that the next buffer of that size is likely to reuse one:
// an entry left unwritten then reads as NaN, not as the zero of a fresh page.
void leaveNaNsOnTheHeap(std::size_t floats) {
  for (int round = 0; round < 2; ++round) {
    std::vector<float> dirt(floats, std::numeric_limits<float>::quiet_NaN());
    asm volatile("" : : "r"(dirt.data()) : "memory");  // the fill must reach memory before the free
  }
}

// The counted sums are written in full on the threads (their buffer starts uninitialised): the same sums
// bit for bit on 1-3 threads, one for each edge, and all 0 when the stop flag is up from the start.
TEST(SecondOrderGraph, CountedSumsAreWrittenInFullOnAnyThreadCount) {
  const CompatibilityGraph fog = randomGraphWithWeightsFrom(900, 0.1, 0.99f, 5);
  const UpperRows rows = upperRowsOf(fog);
  leaveNaNsOnTheHeap(fog.numEdges());
  const EdgeSums one = countedCommonSums(rows, 1);
  ASSERT_EQ(one.size(), fog.numEdges());
  const auto positive = std::count_if(one.begin(), one.end(), [](float sum) { return sum > 0.0f; });
  EXPECT_GT(positive, static_cast<long>(fog.numEdges() / 2));
  for (const int threads : {2, 3}) {
    leaveNaNsOnTheHeap(fog.numEdges());
    const EdgeSums many = countedCommonSums(rows, threads);
    EXPECT_TRUE(std::equal(one.begin(), one.end(), many.begin(), many.end())) << threads << " threads";
  }
  const StopFlag stop{true};
  leaveNaNsOnTheHeap(fog.numEdges());
  const EdgeSums stopped = countedCommonSums(rows, 2, &stop);
  EXPECT_EQ(std::count(stopped.begin(), stopped.end(), 0.0f), static_cast<long>(stopped.size()));
}

// A graph's upper rows are its lists' tails, and the lists built from them on any thread count are the
// graph's own, bit for bit; its second-order work is the same counted from either.
TEST(CompatibilityGraph, ListsOfTheUpperRowsAreTheGraph) {
  CompatibilityGraph g = randomGraphWithWeightsFrom(700, 0.05, 0.9f, 4);
  std::vector<char> keep(700, 1);
  for (int i = 0; i < 700; i += 9) keep[i] = 0;  // isolated nodes
  g = keepNodes(g, keep);
  const UpperRows rows = upperRowsOf(g);
  ASSERT_EQ(rows.numNodes(), g.num_nodes);
  EXPECT_EQ(rows.numEdges(), g.numEdges());
  for (int i = 0; i < g.num_nodes; ++i) {
    ASSERT_EQ(rows.degree[i], g.degree(i));
    for (int c = 0; c < rows.count[i]; ++c) {
      ASSERT_GT(rows.to[i][c], i);
      ASSERT_EQ(rows.weight[i][c], g.weight(i, rows.to[i][c]));
    }
  }
  EXPECT_EQ(secondOrderWork(rows), secondOrderWork(g));
  for (const int threads : {1, 2, 3}) expectSameGraph(graphOfRows(rows, threads), g, std::to_string(threads));
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
