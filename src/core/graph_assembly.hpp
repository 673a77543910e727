// Building the lists of a graph from rows of upper edges, on several threads: shared by graphOfRows and the
// graph of the second-order sums. Internal to the core.
#pragma once

#include <cstdint>
#include <vector>

#include "mac_registration/core/compatibility_graph.hpp"

namespace mac_registration {

// A graph whose node v has degree[v] neighbours: its offsets, and its lists allocated.
CompatibilityGraph graphWithDegrees(const std::vector<std::int64_t>& degree);

// Writes the lower entries of every list of `graph` (the rows that name its node, before its own row at
// the tail): the nodes are split into one range per thread by equal shares of lower entries, each thread
// walking all the rows from a binary search to its range, in ascending row order, so that every list
// comes out ascending without a sort; and in blocks of nodes, so that the lines being written stay cached.
// The rows may be the graph's own tails.
void mirrorRows(const UpperRows& rows, CompatibilityGraph& graph, int num_threads);

}  // namespace mac_registration
