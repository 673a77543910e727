// Graphs as rows of upper edges: building their lists on several threads (shared by graphOfRows and the
// graph of the second-order sums), and their second-order work from degrees alone. Internal to the core.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "compatibility_graph.hpp"

namespace mac_registration {

// secondOrderWork of a graph given each node's degree and the length of its upper row (node j's lower
// neighbours are its degree less its own row, and each costs degree(j)). Integers below 2^53: exact.
template <typename Degree, typename Count>
double secondOrderWorkOfDegrees(const std::vector<Degree>& degree, const std::vector<Count>& row_count) {
  double work = 0.0;
  for (std::size_t j = 0; j < degree.size(); ++j)
    work += double(degree[j] - row_count[j]) * double(degree[j]);
  return work;
}

// A graph whose node v has degree[v] neighbours: its offsets, and its lists allocated.
CompatibilityGraph graphWithDegrees(const std::vector<std::int64_t>& degree);

// Writes the lower entries of every list of `graph` (the rows that name its node, before its own row at
// the tail): the nodes are split into one range per thread by equal shares of lower entries, each thread
// walking all the rows from a binary search to its range, in ascending row order, so that every list
// comes out ascending without a sort; and in blocks of nodes, so that the lines being written stay cached.
// The rows may be the graph's own tails.
void mirrorRows(const UpperRows& rows, CompatibilityGraph& graph, int num_threads);

}  // namespace mac_registration
