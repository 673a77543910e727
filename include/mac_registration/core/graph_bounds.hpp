#pragma once

// The bounds that keep a dense compatibility graph affordable, in one place: the cost of the second-order
// weights, the pruning of dense graphs' weak edges, and the thinning of cores too dense to search for
// cliques. (The first-order pass bounds itself while it runs: graph.max_correspondences and
// graph.max_edges in buildFirstOrderGraph.) Each returns what it did, for the result's warnings.

#include <cstddef>

#include "mac_registration/core/compatibility_graph.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

struct BoundedGraph {
  CompatibilityGraph graph;
  bool reduced = false;        // the bound acted
  std::size_t kept_nodes = 0;  // correspondences left when it did
  std::size_t removed_edges = 0;
};

// graph.max_second_order_work [multiply-adds]: a graph whose second-order pass would cost more keeps only
// its highest-degree nodes (inliers of a dense consensus have the highest degree), shrinking by 30 % a
// round until it fits.
BoundedGraph boundSecondOrderWork(CompatibilityGraph graph, double budget, const StopFlag* stop = nullptr);

// The second-order graph of `first_order`, and whether its weights are the counted estimate.
struct SecondOrderOutcome {
  CompatibilityGraph graph;
  bool counted = false;
};

// graph.dense_mean_degree, before the weights: a first-order graph with a higher mean degree (chance
// compatibilities among many outliers) gets the counted weights of buildCountedSecondOrderGraph when they
// cost less than the exact sums and their bitsets fit; the cut of pruneDenseGraph, which only needs the
// light chance edges told from the heavy consensus ones, follows on such graphs. Sparser graphs (real
// FPFH matches) keep the exact sums of buildSecondOrderGraph. 0 = always exact.
SecondOrderOutcome secondOrderWeights(const CompatibilityGraph& first_order, double dense_mean_degree,
                                      int num_threads, const StopFlag* stop = nullptr);

// graph.dense_mean_degree: a graph with a higher mean degree loses its edges below Otsu's threshold of the
// weights (chance compatibilities between outliers are light, a consensus set's edges heavy); 0 = never.
BoundedGraph pruneDenseGraph(CompatibilityGraph graph, double dense_mean_degree);

// cliques.max_degeneracy: leaves out nodes of the cores above the bound, keeping the strongest of them,
// until the graph's degeneracy is within it. `thinned_nodes` receives how many were left out.
CompatibilityGraph thinDenseCores(const CompatibilityGraph& graph, int max_degeneracy, const StopFlag* stop,
                                  std::size_t& thinned_nodes);

}  // namespace mac_registration
