#pragma once

// The bounds that keep a dense compatibility graph affordable, in one place: the rule of the second-order
// budget (which the first-order pass applies to its rows), the pruning of dense graphs' weak edges, and
// the thinning of cores too dense to search for cliques. (The first-order pass bounds itself while it
// runs: graph.max_correspondences and graph.max_edges in firstOrderRows.) Each returns what it did, for
// the result's warnings.

#include <cstddef>
#include <functional>
#include <vector>

#include "compatibility_graph.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

struct BoundedGraph {
  CompatibilityGraph graph;
  bool reduced = false;        // the bound acted
  std::size_t kept_nodes = 0;  // correspondences left when it did
  std::size_t removed_edges = 0;
};

// graph.max_second_order_work [multiply-adds]: the nodes kept of a graph whose second-order pass would cost
// more: by `degree`, 30 % fewer a round, until `work_of_kept` (the second-order work of the graph among the
// kept nodes, or more once past the budget) is within the budget, 3 nodes are left, or `stop` is raised.
// `kept_nodes` receives how many.
// The first-order pass applies it to its rows before building any list (firstOrderRows); the tests'
// boundSecondOrderWork applies it to a built graph, the reference the pass is held to.
std::vector<char> nodesWithinSecondOrderBudget(
    const std::vector<double>& degree, double budget,
    const std::function<double(const std::vector<char>&)>& work_of_kept, const StopFlag* stop,
    std::size_t& kept_nodes);

// The second-order graph of `first_order` after pruneDenseGraph's cut, and whether its weights are the
// counted estimate.
struct SecondOrderOutcome {
  BoundedGraph pruned;
  bool counted = false;
};

// The second-order weights, then pruneDenseGraph(graph, dense_mean_degree). A first-order graph with a
// higher mean degree than dense_mean_degree (chance compatibilities among many outliers) gets the counted
// weights (countedCommonSums) when they cost less than the exact sums and their bitsets fit: the cut that
// follows on such graphs only needs the light chance edges told from the heavy consensus ones, and is made
// before the graph of all the counted weights is built (the same graph, bit for bit, as cutting it
// afterwards). Sparser graphs (real FPFH matches) keep the exact sums of buildSecondOrderGraph.
// dense_mean_degree 0: exact sums, no cut.
SecondOrderOutcome prunedSecondOrderGraph(const UpperRows& first_order, double dense_mean_degree,
                                          int num_threads, const StopFlag* stop = nullptr);

// graph.dense_mean_degree: a graph with a higher mean degree loses its edges below Otsu's threshold of the
// weights (chance compatibilities between outliers are light, a consensus set's edges heavy); 0 = never.
BoundedGraph pruneDenseGraph(CompatibilityGraph graph, double dense_mean_degree);

// cliques.max_degeneracy: leaves out nodes of the cores above the bound, keeping the strongest of them,
// until the graph's degeneracy is within it. `thinned_nodes` receives how many were left out.
CompatibilityGraph thinDenseCores(const CompatibilityGraph& graph, int max_degeneracy, const StopFlag* stop,
                                  std::size_t& thinned_nodes);

}  // namespace mac_registration
