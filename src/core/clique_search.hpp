#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "compatibility_graph.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

// Receives each maximal clique as it is found: node ids in ascending order. Cliques are streamed, never
// stored by the search.
using CliqueVisitor = std::function<void(const int* nodes, std::size_t size)>;

struct CliqueSearchStats {
  std::size_t cliques = 0;         // cliques streamed over all searches
  int pruning_rounds = 0;          // searches repeated on a pruned graph
  bool complete = true;            // the last search enumerated every maximal clique of its graph
  bool hit_count_limit = false;    // some search stopped at max_cliques
  bool hit_time_limit = false;     // the time budget (cliques.time_limit) ran out
  int degeneracy = 0;              // of the graph given
  std::size_t thinned_nodes = 0;   // left out of the search by the max_degeneracy bound
  std::size_t nodes_searched = 0;  // non-isolated nodes in the last search
  bool cancelled = false;          // the stop flag ended the search
  int stale_igraph_cleanups = 0;  // entries igraph left on its cleanup stack, dropped (0 unless igraph erred)
  std::string error;              // igraph's message when a search failed (not a bound), else empty
  // [ms] Waited for igraph's process-wide lock while other threads searched: not counted in the budget.
  double igraph_wait_ms = 0.0;
};

// Maximal cliques of size >= min_clique_size through igraph's callback search (Eppstein's Bron-Kerbosch
// variant). A graph of higher degeneracy than max_degeneracy first has its dense cores thinned to their
// strongest nodes (see CliqueSearchParams). Bounded by count and time: when a bound stops a search, the graph
// is pruned to its strongest nodes (highest sum of edge weights) and searched again, up to max_pruning_rounds
// times, so that a dense clean graph costs a bounded time instead of an exponential one. Cliques of a pruned
// graph are cliques of the full graph too, so everything streamed stays valid. Serialized process-wide
// (igraph is not thread-safe): a search waits for another thread's to end, and the wait does not count in
// its time budget (CPU time of the calling thread, see CliqueSearchParams::time_limit), so concurrent
// searches of the same graph stream the same cliques. Never aborts the process on an igraph error. A raised
// `stop` ends the search, or the wait for the lock, within a clique, an igraph interruption check or 20 ms
// of waiting, with `cancelled` set.
CliqueSearchStats searchMaximalCliques(const CompatibilityGraph& graph, const CliqueSearchParams& params,
                                       const CliqueVisitor& visit, const StopFlag* stop = nullptr);

// Entries on igraph's process-wide cleanup stack, read under the igraph lock: 0 whenever no search is
// running, or a later igraph error would free memory that is no longer igraph's.
int igraphCleanupStackSize();

}  // namespace mac_registration
