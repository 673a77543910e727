// Clique weights, node-guided selection, the normal-consistency filter and top-K, checked by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

#include "clique_search.hpp"
#include "clique_selection.hpp"
#include "graph_builders.hpp"

namespace mac_registration {
namespace {

using Nodes = std::vector<int>;

// Weights chosen so that, by hand:
//   A = {0,1,2}: 1 + 1 + 1 = 3          B = {1,2,3}: 1 + 1.5 + 1.5 = 4      C = {3,4,5}: 1 + 1 + 1 = 3
//   F = {0,3,4}: 0.5 + 1.5 + 1 = 3      K = {0,1,2,3}: 1 + 1 + 0.5 + 1 + 1.5 + 1.5 = 6.5
// All weights are exact in float and their sums exact in double, so weights compare exactly.
CompatibilityGraph handGraph() {
  return graphFromUpperRows(6, {{{1, 1.0f}, {2, 1.0f}, {3, 0.5f}, {4, 1.5f}},
                                {{2, 1.0f}, {3, 1.5f}},
                                {{3, 1.5f}},
                                {{4, 1.0f}, {5, 1.0f}},
                                {{5, 1.0f}},
                                {}});
}
const Nodes kA = {0, 1, 2}, kB = {1, 2, 3}, kC = {3, 4, 5}, kF = {0, 3, 4}, kK = {0, 1, 2, 3};

double weightOf(const CompatibilityGraph& g, const Nodes& nodes) {
  return cliqueWeight(g, nodes.data(), nodes.size());
}

std::vector<Nodes> nodesOf(const std::vector<SelectedClique>& cliques) {
  std::vector<Nodes> out;
  for (const auto& c : cliques) out.push_back(c.nodes);
  return out;
}

std::vector<SelectedClique> select(const CompatibilityGraph& g, const std::vector<Nodes>& offers) {
  NodeGuidedSelector selector(g);
  for (const auto& nodes : offers) selector.offer(nodes.data(), nodes.size());
  const auto selected = selector.selected();
  const std::vector<Nodes> lists = nodesOf(selected);
  EXPECT_EQ(std::set<Nodes>(lists.begin(), lists.end()).size(), lists.size()) << "a clique was emitted twice";
  return selected;
}

TEST(CliqueWeight, ByHand) {
  const CompatibilityGraph g = handGraph();
  EXPECT_EQ(weightOf(g, kA), 3.0);
  EXPECT_EQ(weightOf(g, kB), 4.0);
  EXPECT_EQ(weightOf(g, kK), 6.5);
  EXPECT_EQ(weightOf(g, {0, 1, 5}), 1.0);  // only edges present count
  EXPECT_EQ(weightOf(g, {4, 5}), 1.0);
  EXPECT_EQ(weightOf(g, {2, 5}), 0.0);
  EXPECT_EQ(weightOf(g, {3}), 0.0);
}

TEST(NodeGuidedSelector, HeavierReplacesAndOutputIsOrderedByLowestKeepingNode) {
  const CompatibilityGraph g = handGraph();
  // C first, then B (heavier at node 3), then A (lighter than B at 1 and 2, kept only by node 0).
  const auto selected = select(g, {kC, kB, kA});
  EXPECT_EQ(nodesOf(selected), (std::vector<Nodes>{kA, kB, kC}));  // kept by nodes 0, 1 and 4
  ASSERT_EQ(selected.size(), 3u);
  EXPECT_EQ(selected[0].weight, 3.0);
  EXPECT_EQ(selected[1].weight, 4.0);
  EXPECT_EQ(selected[2].weight, 3.0);
}

TEST(NodeGuidedSelector, FirstOfEqualWeightsWins) {
  const CompatibilityGraph g = handGraph();
  // A and F both weigh 3 and share node 0: node 0 keeps whichever came first.
  EXPECT_EQ(nodesOf(select(g, {kA, kF})), (std::vector<Nodes>{kA, kF}));  // node 0 -> A, node 3 -> F
  EXPECT_EQ(nodesOf(select(g, {kF, kA})), (std::vector<Nodes>{kF, kA}));  // node 0 -> F, node 1 -> A
  EXPECT_EQ(nodesOf(select(g, {kA, kA})), (std::vector<Nodes>{kA}));      // offered twice, kept once
}

TEST(NodeGuidedSelector, ReplacedCliqueIsDroppedAndItsSlotReused) {
  const CompatibilityGraph g = handGraph();
  // K beats A at all of A's nodes, so A disappears; C then takes nodes 4 and 5 (node 3 keeps K), and
  // B, lighter than K everywhere, is not kept at all.
  const auto selected = select(g, {kA, kK, kC, kB});
  EXPECT_EQ(nodesOf(selected), (std::vector<Nodes>{kK, kC}));
  ASSERT_EQ(selected.size(), 2u);
  EXPECT_EQ(selected[0].weight, 6.5);
  EXPECT_EQ(selected[1].weight, 3.0);
}

TEST(NodeGuidedSelector, NothingOffered) { EXPECT_TRUE(select(handGraph(), {}).empty()); }

// Random graphs: node 0 is a hub joined to every other node (its list is longer than a small cache, so
// the cache looks the cached nodes up in it), the others are joined with probability `density`. Weights
// either from {0.5, 1, 1.5, 2} (exact sums, so that different cliques often weigh the same) or uniform in
// (0, 1].
CompatibilityGraph randomGraph(int n, double density, bool tied_weights, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<std::vector<UpperEdge>> rows(n);
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      if (a != 0 && uniform(rng) >= density) continue;
      const float weight = tied_weights ? 0.5f * float(1 + rng() % 4) : float(1.0 - uniform(rng));
      rows[a].push_back({b, weight});
    }
  }
  return graphFromUpperRows(n, rows);
}

std::vector<Nodes> allMaximalCliques(const CompatibilityGraph& g) {
  std::vector<Nodes> cliques;
  CliqueSearchParams params;
  params.max_degeneracy = 0;
  params.max_pruning_rounds = 0;
  const CliqueSearchStats stats = searchMaximalCliques(
      g, params, [&](const int* nodes, std::size_t size) { cliques.emplace_back(nodes, nodes + size); });
  EXPECT_TRUE(stats.complete);
  return cliques;
}

// The selection spelled out: every clique's weight by cliqueWeight, each node keeping the first of its
// heaviest cliques in the order given, the distinct kept cliques in the order of their lowest keeping node.
std::vector<SelectedClique> perNodeHeaviest(const CompatibilityGraph& g, const std::vector<Nodes>& cliques,
                                            int& ties) {
  std::vector<double> weight(cliques.size());
  for (std::size_t k = 0; k < cliques.size(); ++k) weight[k] = weightOf(g, cliques[k]);
  std::vector<int> kept(g.num_nodes, -1);
  for (std::size_t k = 0; k < cliques.size(); ++k) {
    for (int node : cliques[k]) {
      if (kept[node] != -1 && weight[k] == weight[kept[node]]) ++ties;
      if (kept[node] == -1 || weight[k] > weight[kept[node]]) kept[node] = static_cast<int>(k);
    }
  }
  std::vector<SelectedClique> out;
  std::set<int> emitted;
  for (int k : kept) {
    if (k == -1 || !emitted.insert(k).second) continue;
    out.push_back({cliques[k], weight[k]});
  }
  return out;
}

TEST(CliqueWeightCache, BitIdenticalToCliqueWeight) {
  for (std::uint32_t seed = 1; seed <= 30; ++seed) {
    for (double density : {0.1, 0.3, 0.6}) {
      const CompatibilityGraph g = randomGraph(60, density, seed % 2 == 0, seed);
      const std::vector<Nodes> cliques = allMaximalCliques(g);
      ASSERT_FALSE(cliques.empty());
      for (int capacity : {3, 8, 256}) {  // 3 and 8: cliques larger than the matrix, and frequent clears
        CliqueWeightCache cache(g, capacity);
        for (const Nodes& clique : cliques) {
          ASSERT_EQ(cache.weight(clique.data(), clique.size()), weightOf(g, clique))
              << "seed " << seed << ", density " << density << ", capacity " << capacity;
        }
      }
    }
  }
}

TEST(NodeGuidedSelector, MatchesThePerNodeHeaviestOfAllMaximalCliques) {
  int ties = 0, cases = 0;
  for (std::uint32_t seed = 1; seed <= 60; ++seed) {
    for (double density : {0.05, 0.2, 0.4, 0.7}) {
      for (bool tied_weights : {true, false}) {
        const CompatibilityGraph g = randomGraph(40, density, tied_weights, seed);
        const std::vector<Nodes> cliques = allMaximalCliques(g);
        const std::vector<SelectedClique> expected = perNodeHeaviest(g, cliques, ties);
        const std::vector<SelectedClique> selected = select(g, cliques);
        ASSERT_EQ(nodesOf(selected), nodesOf(expected)) << "seed " << seed << ", density " << density;
        for (std::size_t k = 0; k < selected.size(); ++k) ASSERT_EQ(selected[k].weight, expected[k].weight);
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 480);
  EXPECT_GT(ties, 100) << "the tied weights should make equal-weight cliques meet at a node";
}

// Thousands of cliques, so that many batches are handed to the selector's thread while the search goes on.
TEST(StreamedSelection, ConcurrentIsTheInlineSelection) {
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    const CompatibilityGraph g = randomGraph(150, 0.3, seed % 2 == 0, seed);
    const std::vector<Nodes> cliques = allMaximalCliques(g);
    ASSERT_GT(cliques.size(), 4000u);
    std::vector<SelectedClique> selections[2];
    for (const bool concurrent : {false, true}) {
      StreamedSelection streamed(g, concurrent);
      for (const Nodes& clique : cliques) streamed.add(clique.data(), clique.size());
      streamed.finish();
      selections[concurrent] = streamed.selector().selected();
    }
    ASSERT_EQ(nodesOf(selections[1]), nodesOf(selections[0])) << "seed " << seed;
    for (std::size_t k = 0; k < selections[0].size(); ++k)
      ASSERT_EQ(selections[1][k].weight, selections[0][k].weight);
    EXPECT_EQ(nodesOf(selections[0]), nodesOf(select(g, cliques)));
  }
}

// Normals: pair (0,3) has source sine 0 but target sine 0.5 (30 deg); pair (2,3) has source sine 1 but
// target sine sin(60 deg) = 0.866; every other pair has sine 1 on both sides. Node 1's target normal is
// flipped and node 2's source normal has length 2: neither changes a sine.
CorrespondenceSet normalsCase() {
  CorrespondenceSet c;
  c.source_points = Eigen::Matrix3Xd::Zero(3, 4);
  c.target_points = Eigen::Matrix3Xd::Zero(3, 4);
  c.source_normals.resize(3, 4);
  c.target_normals.resize(3, 4);
  c.source_normals << 0, 1, 0, 0,  //
      0, 0, 2, 0,                  //
      1, 0, 0, 1;
  const double s30 = 0.5, c30 = std::sqrt(3.0) / 2.0;
  c.target_normals << 0, -1, 0, 0,  //
      0, 0, 1, s30,                 //
      1, 0, 0, c30;
  return c;
}

TEST(NormalConsistency, HandMadeNormals) {
  const CorrespondenceSet c = normalsCase();
  ASSERT_TRUE(c.hasNormals());
  const std::vector<SelectedClique> cliques = {{{0, 1, 2}, 5.0}, {{1, 2, 3}, 4.0}, {{0, 1, 3}, 3.0}};
  // |sin a_s - sin a_t|: {0,1,2} all 0; {1,2,3} worst 0.134; {0,1,3} worst 0.5.
  EXPECT_EQ(nodesOf(normalConsistentCliques(cliques, c, 0.1)), (std::vector<Nodes>{{0, 1, 2}}));
  EXPECT_EQ(nodesOf(normalConsistentCliques(cliques, c, 0.2)), (std::vector<Nodes>{{0, 1, 2}, {1, 2, 3}}));
  const auto all = normalConsistentCliques(cliques, c, 0.6);
  EXPECT_EQ(nodesOf(all), (std::vector<Nodes>{{0, 1, 2}, {1, 2, 3}, {0, 1, 3}}));
  EXPECT_EQ(all[1].weight, 4.0);  // weights carried through
}

TEST(HeaviestCliques, TopKOrderAndStability) {
  // nodes[0] tags each clique so that its position can be followed.
  const std::vector<SelectedClique> cliques = {{{0}, 1.0}, {{1}, 3.0}, {{2}, 2.0}, {{3}, 3.0}, {{4}, 1.0}};
  const auto tags = [](const std::vector<SelectedClique>& v) {
    std::vector<int> out;
    for (const auto& c : v) out.push_back(c.nodes[0]);
    return out;
  };
  EXPECT_EQ(tags(heaviestCliques(cliques, 0)),
            (std::vector<int>{1, 3, 2, 0, 4}));  // equal weights keep order
  EXPECT_EQ(tags(heaviestCliques(cliques, 2)), (std::vector<int>{1, 3}));
  EXPECT_EQ(tags(heaviestCliques(cliques, 3)), (std::vector<int>{1, 3, 2}));
  EXPECT_EQ(tags(heaviestCliques(cliques, 10)), (std::vector<int>{1, 3, 2, 0, 4}));
  EXPECT_TRUE(heaviestCliques({}, 3).empty());
}

}  // namespace
}  // namespace mac_registration
