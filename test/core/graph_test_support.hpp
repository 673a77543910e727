// Shared by the graph tests: the invariants every CompatibilityGraph keeps.
#pragma once

#include <gtest/gtest.h>

#include "compatibility_graph.hpp"

namespace mac_registration::test {

// Offsets consistent, lists strictly ascending, no self loops, every edge stored both ways with one weight.
inline void expectValidGraph(const CompatibilityGraph& g) {
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

}  // namespace mac_registration::test
