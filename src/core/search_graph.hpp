// The graph the clique search hands to igraph: the edges that can be in a clique, with true twins merged.
// Internal to the core.
#pragma once

#include <igraph.h>

#include <vector>

#include "compatibility_graph.hpp"
#include "mac_registration/core/parameters.hpp"

namespace mac_registration {

// The graph the search hands to igraph, as an edge list over its own vertices, each vertex one node or a
// set of true twins. With min_clique_size 3 or more (every valid configuration), only the edges that lie
// in a triangle, and the nodes they join, are kept: such a clique is made of those edges alone, and one
// that is maximal stays maximal without the others, so the cliques are the same. igraph's enumeration
// clears a vector of all its vertices for each vertex it starts from, so the nodes left out would make it
// quadratic for nothing: a chance graph after Otsu's cut keeps many edges in no triangle, and a graph
// reduced or thinned from a large set mostly isolated nodes (igraph 0.10: 1.3 s for 100 000 isolated
// vertices, 16 s for 300 000).
struct SearchGraph {
  std::vector<int> member_begin;        // per vertex, into members (one more entry than vertices)
  std::vector<int> members;             // graph nodes, ascending within each vertex
  std::vector<igraph_integer_t> edges;  // vertex pairs
  bool merged = false;                  // some vertex holds several nodes
};

// The search graph of `graph` for `params`: the same maximal cliques of min_clique_size or more nodes as
// `graph`, node for node, once each vertex stands for its members. Twins are merged only without a size
// cap (a cap counts nodes, not vertices).
SearchGraph searchGraph(const CompatibilityGraph& graph, const CliqueSearchParams& params);

}  // namespace mac_registration
