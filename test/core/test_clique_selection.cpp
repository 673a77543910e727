// Clique weights, node-guided selection, the normal-consistency filter and top-K, checked by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "mac_registration/core/clique_selection.hpp"

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
