// Graph builders only the tests call: references the product's paths are held to (the lists of upper
// rows edge by edge, the first-order graph as lists, the counted second-order graph in one call, the
// second-order budget on a built graph), composed of the core's stages. They were the core's and moved
// here because the library itself never calls them.
#pragma once

#include <vector>

#include "compatibility_graph.hpp"
#include "graph_bounds.hpp"

namespace mac_registration {

// Builds a graph from upper-triangle edge lists: rows[i] holds (j, w) with j > i, ascending in j.
struct UpperEdge {
  int to;
  float weight;
};
CompatibilityGraph graphFromUpperRows(int num_nodes, const std::vector<std::vector<UpperEdge>>& rows);

// The first-order graph as lists.
struct FirstOrderGraph : FirstOrderBounds {
  CompatibilityGraph graph;
};

// firstOrderRows with its graph's lists built.
FirstOrderGraph buildFirstOrderGraph(const CorrespondenceSet& correspondences, const GraphParams& params,
                                     int num_threads, const StopFlag* stop = nullptr,
                                     double second_order_budget = 0.0);

// Eq. 4 estimated from counts, for dense graphs: sum_k S_ik S_jk is taken as c_ij m_i m_j, with c_ij the
// number of common neighbours of i and j (a popcount of two neighbour bitsets) and m_i the mean weight of
// i's edges. Every weight lies in [t_cmp, 1], so the estimate is within a factor t_cmp^2 of the exact sum
// (2 % at t_cmp 0.99); the same edges as buildSecondOrderGraph (those in a triangle). O(N) words per
// edge instead of O(degree) random loads, and O(N^2 / 8) bytes of bitsets; the same graph whatever
// num_threads. A raised `stop` leaves it incomplete, as buildSecondOrderGraph.
CompatibilityGraph buildCountedSecondOrderGraph(const CompatibilityGraph& first_order, int num_threads,
                                                const StopFlag* stop = nullptr);

// graph.max_second_order_work [multiply-adds]: a graph whose second-order pass would cost more keeps only
// its highest-degree nodes (inliers of a dense consensus have the highest degree), shrinking by 30 % a
// round until it fits.
BoundedGraph boundSecondOrderWork(CompatibilityGraph graph, double budget, int num_threads = 1,
                                  const StopFlag* stop = nullptr);

}  // namespace mac_registration
