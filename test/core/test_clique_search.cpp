// Maximal clique search on small graphs whose cliques are known by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <future>
#include <iterator>
#include <memory>
#include <mutex>
#include <numeric>
#include <random>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "clique_search.hpp"
#include "graph_builders.hpp"

namespace mac_registration {
namespace {

using Clique = std::vector<int>;

// Unweighted (weight 1) graph from an edge list.
CompatibilityGraph graphFromEdges(int n, std::vector<std::pair<int, int>> edges) {
  std::sort(edges.begin(), edges.end());
  std::vector<std::vector<UpperEdge>> rows(n);
  for (const auto& [a, b] : edges) rows[a].push_back({b, 1.0f});
  return graphFromUpperRows(n, rows);
}

// Streams the cliques into a list; each must arrive in strictly ascending node order.
struct Collected {
  CliqueSearchStats stats;
  std::vector<Clique> cliques;  // sorted, for comparison
};

Collected search(const CompatibilityGraph& graph, const CliqueSearchParams& params) {
  Collected out;
  out.stats = searchMaximalCliques(graph, params, [&](const int* nodes, std::size_t size) {
    Clique clique(nodes, nodes + size);
    EXPECT_TRUE(std::adjacent_find(clique.begin(), clique.end(), std::greater_equal<int>()) == clique.end())
        << "clique not strictly ascending";
    out.cliques.push_back(clique);
  });
  std::sort(out.cliques.begin(), out.cliques.end());
  return out;
}

TEST(CliqueSearch, TwoTrianglesSharingAnEdge) {
  const auto result = search(graphFromEdges(4, {{0, 1}, {0, 2}, {1, 2}, {1, 3}, {2, 3}}), {});
  EXPECT_EQ(result.cliques, (std::vector<Clique>{{0, 1, 2}, {1, 2, 3}}));
  EXPECT_EQ(result.stats.cliques, 2u);
  EXPECT_TRUE(result.stats.complete);
  EXPECT_FALSE(result.stats.hit_count_limit);
  EXPECT_EQ(result.stats.pruning_rounds, 0);
  EXPECT_EQ(result.stats.nodes_searched, 4u);
  EXPECT_TRUE(result.stats.error.empty());
}

// K4 on 0-3 plus a triangle 3-4-5 hanging off node 3, and an isolated node 6.
CompatibilityGraph k4AndPendantTriangle() {
  return graphFromEdges(7, {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}, {3, 4}, {3, 5}, {4, 5}});
}

TEST(CliqueSearch, K4AndPendantTriangle) {
  const auto result = search(k4AndPendantTriangle(), {});
  EXPECT_EQ(result.cliques, (std::vector<Clique>{{0, 1, 2, 3}, {3, 4, 5}}));
  EXPECT_EQ(result.stats.nodes_searched, 6u);  // node 6 is isolated
}

TEST(CliqueSearch, MinCliqueSizeFilters) {
  CliqueSearchParams params;
  params.min_clique_size = 4;
  const auto result = search(k4AndPendantTriangle(), params);
  EXPECT_EQ(result.cliques, (std::vector<Clique>{{0, 1, 2, 3}}));
  EXPECT_TRUE(result.stats.complete);
}

TEST(CliqueSearch, NoTriangleNoClique) {
  // A 5-cycle plus a pendant edge: maximal cliques are all edges, none of size >= 3.
  const auto result = search(graphFromEdges(6, {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {0, 4}, {4, 5}}), {});
  EXPECT_TRUE(result.cliques.empty());
  EXPECT_EQ(result.stats.cliques, 0u);
  EXPECT_TRUE(result.stats.complete);

  const auto empty = search(graphFromEdges(3, {}), {});
  EXPECT_TRUE(empty.cliques.empty());
  EXPECT_EQ(empty.stats.nodes_searched, 0u);
}

// Eight disjoint triangles of equal weight: every pruning round keeps half the nodes, which (ties to the
// lower index) are whole triangles again, so every round still has more cliques than the bound.
CompatibilityGraph disjointTriangles(int count) {
  std::vector<std::pair<int, int>> edges;
  for (int t = 0; t < count; ++t)
    edges.insert(edges.end(), {{3 * t, 3 * t + 1}, {3 * t, 3 * t + 2}, {3 * t + 1, 3 * t + 2}});
  return graphFromEdges(3 * count, edges);
}

// Every maximal clique of at least `min_size` nodes, by Bron-Kerbosch without a pivot over all the nodes:
// slow and plain, the reference for the search.
std::vector<Clique> maximalCliquesByHand(const CompatibilityGraph& graph, std::size_t min_size) {
  std::vector<Clique> out;
  const std::function<void(Clique, std::vector<int>, std::vector<int>)> extend =
      [&](Clique r, std::vector<int> p, std::vector<int> x) {
        if (p.empty() && x.empty()) {
          if (r.size() >= min_size) out.push_back(r);
          return;
        }
        while (!p.empty()) {
          const int v = p.front();
          const auto adjacent = [&](int u) { return graph.weight(u, v) > 0.0f; };
          std::vector<int> p_next, x_next;
          std::copy_if(p.begin(), p.end(), std::back_inserter(p_next), adjacent);
          std::copy_if(x.begin(), x.end(), std::back_inserter(x_next), adjacent);
          Clique grown = r;
          grown.insert(std::upper_bound(grown.begin(), grown.end(), v), v);
          extend(grown, p_next, x_next);
          p.erase(p.begin());
          x.push_back(v);
        }
      };
  std::vector<int> all(graph.num_nodes);
  std::iota(all.begin(), all.end(), 0);
  extend({}, all, {});
  std::sort(out.begin(), out.end());
  return out;
}

// Only the edges in a triangle go to igraph: on random graphs with many edges in none (pendant paths,
// chance edges between cliques), the cliques are the reference's, for minimum sizes 3 and 4; with a
// minimum of 2 every edge is kept and the lone edges are cliques too.
TEST(CliqueSearch, EdgesInNoTriangleChangeNoClique) {
  std::mt19937 rng(5);
  for (const double density : {0.05, 0.15, 0.3}) {
    std::vector<std::pair<int, int>> edges;
    std::bernoulli_distribution edge(density);
    for (int a = 0; a < 36; ++a)
      for (int b = a + 1; b < 36; ++b)
        if (edge(rng)) edges.push_back({a, b});
    for (int a = 36; a + 1 < 48; ++a) edges.push_back({a, a + 1});  // a path: no triangle
    const CompatibilityGraph graph = graphFromEdges(48, edges);
    for (const int min_size : {2, 3, 4}) {
      CliqueSearchParams params;
      params.min_clique_size = min_size;
      EXPECT_EQ(search(graph, params).cliques, maximalCliquesByHand(graph, std::size_t(min_size)))
          << "density " << density << ", min size " << min_size;
    }
  }
}

// True twins (complete subgraphs, nodes joined to all of one) go to igraph as one vertex each: the cliques
// are still the reference's, node for node, including a merged vertex that is a clique alone and one too
// small to be reported; with a size cap nothing is merged and the cap still holds.
TEST(CliqueSearch, MergedTwinsChangeNoClique) {
  std::mt19937 rng(11);
  std::vector<std::pair<int, int>> edges;
  const auto complete = [&](std::vector<int> nodes) {
    for (std::size_t a = 0; a < nodes.size(); ++a)
      for (std::size_t b = a + 1; b < nodes.size(); ++b) edges.push_back({nodes[a], nodes[b]});
  };
  std::vector<int> core(14);
  std::iota(core.begin(), core.end(), 3);  // 3..16, twins but for what joins some of them below
  complete(core);
  for (int v = 0; v < 3; ++v)  // three nodes each joined to the first ten of the core
    for (int k = 0; k < 10; ++k) edges.push_back({v, core[k]});
  complete({20, 21, 22, 23, 24});  // a clique alone
  complete({30, 31});              // an edge alone
  std::bernoulli_distribution edge(0.2);
  for (int a = 40; a < 60; ++a)
    for (int b = a + 1; b < 60; ++b)
      if (edge(rng)) edges.push_back({a, b});
  for (int a = 40; a < 45; ++a) edges.push_back({16, a});  // the core's last node gets a few more
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const CompatibilityGraph graph = graphFromEdges(60, edges);
  for (const int min_size : {3, 4, 6, 12}) {
    CliqueSearchParams params;
    params.min_clique_size = min_size;
    const auto found = search(graph, params);
    EXPECT_EQ(found.cliques, maximalCliquesByHand(graph, std::size_t(min_size))) << "min size " << min_size;
    EXPECT_EQ(found.stats.cliques, found.cliques.size());
  }
  CliqueSearchParams capped;
  capped.max_clique_size = 5;
  const auto capped_cliques = search(graph, capped).cliques;
  ASSERT_FALSE(capped_cliques.empty());
  for (const Clique& clique : capped_cliques) EXPECT_LE(clique.size(), 5u);
}

TEST(CliqueSearch, IsolatedNodesKeepTheirIdsAndCostNothing) {
  // A triangle among 300 000 nodes, the shape of a graph reduced from a large correspondence set. Handed
  // to igraph whole, its enumeration would be quadratic in the node count (over 10 s).
  CliqueSearchParams params;
  params.time_limit = 10.0;
  const auto result = search(graphFromEdges(300000, {{5, 100000}, {5, 299999}, {100000, 299999}}), params);
  EXPECT_EQ(result.cliques, (std::vector<Clique>{{5, 100000, 299999}}));
  EXPECT_TRUE(result.stats.complete);
  EXPECT_EQ(result.stats.nodes_searched, 3u);
}

TEST(CliqueSearch, CountLimitWithoutPruning) {
  CliqueSearchParams params;
  params.max_cliques = 1;
  params.max_pruning_rounds = 0;
  const auto result = search(disjointTriangles(8), params);
  EXPECT_EQ(result.cliques.size(), 1u);
  EXPECT_EQ(result.stats.cliques, 1u);
  EXPECT_TRUE(result.stats.hit_count_limit);
  EXPECT_FALSE(result.stats.complete);
  EXPECT_EQ(result.stats.pruning_rounds, 0);
}

TEST(CliqueSearch, CountLimitPrunesAndRetries) {
  CliqueSearchParams params;
  params.max_cliques = 1;
  params.max_pruning_rounds = 2;
  params.time_limit = 30.0;  // only the count bound may stop these searches
  const auto result = search(disjointTriangles(8), params);
  // 24 nodes -> 12 -> 6, one clique streamed per search.
  EXPECT_EQ(result.stats.pruning_rounds, 2);
  EXPECT_EQ(result.stats.cliques, 3u);
  EXPECT_EQ(result.cliques.size(), 3u);
  EXPECT_EQ(result.stats.nodes_searched, 6u);
  EXPECT_TRUE(result.stats.hit_count_limit);
  EXPECT_FALSE(result.stats.hit_time_limit);
  EXPECT_FALSE(result.stats.complete);
  for (const auto& clique : result.cliques) {  // every streamed clique is a triangle of the full graph
    ASSERT_EQ(clique.size(), 3u);
    EXPECT_EQ(clique[0] % 3, 0);
    EXPECT_EQ(clique[1], clique[0] + 1);
    EXPECT_EQ(clique[2], clique[0] + 2);
  }
}

TEST(CliqueSearch, PrunedSearchCanComplete) {
  // Two triangles sharing an edge, bound 1: pruning to the 2 strongest nodes leaves no triangle, so the
  // retry enumerates its (empty) graph completely.
  CliqueSearchParams params;
  params.max_cliques = 1;
  params.max_pruning_rounds = 3;
  params.time_limit = 30.0;
  const auto result = search(graphFromEdges(4, {{0, 1}, {0, 2}, {1, 2}, {1, 3}, {2, 3}}), params);
  EXPECT_TRUE(result.stats.hit_count_limit);
  EXPECT_EQ(result.stats.pruning_rounds, 1);
  EXPECT_TRUE(result.stats.complete);
  EXPECT_EQ(result.stats.cliques, 1u);
}

TEST(CliqueSearch, MaxDegeneracyThinsDenseCores) {
  // K5 (nodes 0-4) has degeneracy 4; a bound of 3 keeps its 3 strongest nodes and leaves out 2: node 4,
  // whose pendant edge to 5 makes it the strongest, then 0 and 1 (ties go to the lower index). Node 5
  // (core 1) is never thinned, but {4,5} is too small to report.
  std::vector<std::pair<int, int>> edges = {{4, 5}};
  for (int a = 0; a < 5; ++a) {
    for (int b = a + 1; b < 5; ++b) edges.push_back({a, b});
  }
  CliqueSearchParams params;
  params.max_degeneracy = 3;
  const auto thinned = search(graphFromEdges(6, edges), params);
  EXPECT_EQ(thinned.stats.degeneracy, 4);
  EXPECT_EQ(thinned.stats.thinned_nodes, 2u);
  EXPECT_EQ(thinned.cliques, (std::vector<Clique>{{0, 1, 4}}));

  params.max_degeneracy = 0;  // no bound
  const auto full = search(graphFromEdges(6, edges), params);
  EXPECT_EQ(full.stats.thinned_nodes, 0u);
  EXPECT_EQ(full.cliques, (std::vector<Clique>{{0, 1, 2, 3, 4}}));
}

// A cycle has no triangle: the search streams nothing, so only igraph's interruption checks (in its core
// decomposition, its set-up and its loop over vertices) can stop it at the deadline.

TEST(CliqueSearch, InterruptedSearchesLeaveIgraphClean) {
  // A thousand searches stopped at deadlines spread from before igraph starts to after it finishes, so
  // that igraph is interrupted inside nested functions as well as in its main loop. An interrupted igraph
  // function leaves its temporaries on igraph's cleanup stack; left there, they either fill it (igraph
  // then aborts the process) or are freed by the next igraph error after their frames are gone.
  // 1334 triangles (4002 nodes) searched for cliques of 4: igraph works through every vertex and finds none.
  const CompatibilityGraph graph = disjointTriangles(1334);
  CliqueSearchParams params;
  params.min_clique_size = 4;
  params.max_pruning_rounds = 0;
  int interrupted = 0;
  for (int call = 0; call < 1000; ++call) {
    params.time_limit = 1e-7 * std::pow(10.0, 4.0 * (call % 100) / 99.0);  // 0.1 us .. 1 ms
    const CliqueSearchStats stats = searchMaximalCliques(graph, params, [](const int*, std::size_t) {});
    ASSERT_TRUE(stats.error.empty()) << "call " << call << ": " << stats.error;
    ASSERT_EQ(stats.stale_igraph_cleanups, 0) << "call " << call << " left igraph temporaries behind";
    ASSERT_EQ(igraphCleanupStackSize(), 0) << "call " << call;
    EXPECT_EQ(stats.cliques, 0u);
    interrupted += stats.hit_time_limit;
  }
  EXPECT_GT(interrupted, 0);  // a 0.1 us budget is over before igraph starts

  // igraph still works, errors included.
  const auto result = search(k4AndPendantTriangle(), {});
  EXPECT_EQ(result.cliques, (std::vector<Clique>{{0, 1, 2, 3}, {3, 4, 5}}));
  EXPECT_TRUE(result.stats.complete);
  EXPECT_EQ(igraphCleanupStackSize(), 0);
}

TEST(CliqueSearch, RaisedStopFlagCancelsBeforeSearching) {
  const StopFlag stop{true};
  std::size_t streamed = 0;
  const CliqueSearchStats stats = searchMaximalCliques(
      disjointTriangles(8), {}, [&](const int*, std::size_t) { ++streamed; }, &stop);
  EXPECT_TRUE(stats.cancelled);
  EXPECT_FALSE(stats.complete);
  EXPECT_EQ(streamed, 0u);
}

TEST(CliqueSearch, StopFlagRaisedDuringTheSearchEndsIt) {
  // Raised by the visitor itself: the search stops after the clique that raised it, not at a bound.
  StopFlag stop{false};
  std::size_t streamed = 0;
  CliqueSearchParams params;
  params.time_limit = 30.0;
  const CliqueSearchStats stats = searchMaximalCliques(
      disjointTriangles(8), params,
      [&](const int*, std::size_t) {
        ++streamed;
        stop = true;
      },
      &stop);
  EXPECT_TRUE(stats.cancelled);
  EXPECT_FALSE(stats.complete);
  EXPECT_FALSE(stats.hit_time_limit);
  EXPECT_EQ(stats.pruning_rounds, 0);
  EXPECT_EQ(streamed, 1u);
  EXPECT_EQ(igraphCleanupStackSize(), 0);
}

TEST(CliqueSearch, ThrowingVisitorPropagatesAndReleasesLock) {
  const CompatibilityGraph graph = k4AndPendantTriangle();
  EXPECT_THROW(
      searchMaximalCliques(graph, {}, [](const int*, std::size_t) { throw std::runtime_error("stop"); }),
      std::runtime_error);

  // If the process-wide igraph lock were still held, this search would block forever: run it on a
  // detached thread and give it 20 s (it takes microseconds) instead of hanging the test binary.
  auto task = std::make_shared<std::packaged_task<Collected()>>([graph] { return search(graph, {}); });
  std::future<Collected> done = task->get_future();
  std::thread([task] { (*task)(); }).detach();
  ASSERT_EQ(done.wait_for(std::chrono::seconds(20)), std::future_status::ready) << "igraph lock not released";
  EXPECT_EQ(done.get().cliques, (std::vector<Clique>{{0, 1, 2, 3}, {3, 4, 5}}));
}

// Another thread's search that holds igraph's lock from its first clique until released (or 30 s):
// what a concurrent registration's long search is to this one.
class LockHolder {
 public:
  LockHolder() {
    const std::shared_future<void> released = release_.get_future().share();
    holding_ = std::async(std::launch::async, [this, released] {
      CliqueSearchParams params;
      params.time_limit = 60.0;
      return searchMaximalCliques(disjointTriangles(2), params, [this, released](const int*, std::size_t) {
        std::call_once(entered_once_, [this] { entered_.set_value(); });
        released.wait_for(std::chrono::seconds(30));
      });
    });
    entered_.get_future().wait();
  }
  ~LockHolder() { release(); }
  void release() {
    std::call_once(released_once_, [this] { release_.set_value(); });
    holding_.wait();
  }

 private:
  std::promise<void> entered_, release_;
  std::once_flag entered_once_, released_once_;
  std::future<CliqueSearchStats> holding_;
};

// A registration queued behind another's search gets its whole budget once igraph is its own: the wait
// for the lock is not search time, so the result is the one it gets alone.
TEST(CliqueSearch, TheWaitForIgraphSpendsNoBudget) {
  const CompatibilityGraph graph = disjointTriangles(3000);
  CliqueSearchParams params;
  params.time_limit = 0.3;
  const Collected alone = search(graph, params);
  ASSERT_TRUE(alone.stats.complete);
  ASSERT_EQ(alone.cliques.size(), 3000u);
  EXPECT_LT(alone.stats.igraph_wait_ms, 100.0);

  LockHolder holder;
  auto queued = std::async(std::launch::async, [&] { return search(graph, params); });
  // Queued for three times its budget, then igraph is free.
  ASSERT_EQ(queued.wait_for(std::chrono::milliseconds(900)), std::future_status::timeout)
      << "searched while another search held igraph";
  holder.release();
  ASSERT_EQ(queued.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  const Collected after_waiting = queued.get();
  EXPECT_GE(after_waiting.stats.igraph_wait_ms, 850.0);
  EXPECT_TRUE(after_waiting.stats.complete);
  EXPECT_FALSE(after_waiting.stats.hit_time_limit);
  EXPECT_EQ(after_waiting.stats.pruning_rounds, 0);
  EXPECT_EQ(after_waiting.cliques, alone.cliques);
}

// The budget is the search's CPU time: time the searching thread spends off the core (here asleep in the
// visitor, as it is when the machine is busy with other work) does not run it out.
TEST(CliqueSearch, TimeOffTheCoreSpendsNoBudget) {
  CliqueSearchParams params;
  params.time_limit = 0.1;
  std::size_t streamed = 0;
  const CliqueSearchStats stats =
      searchMaximalCliques(disjointTriangles(20), params, [&](const int*, std::size_t) {
        ++streamed;
        std::this_thread::sleep_for(std::chrono::milliseconds(15));  // 0.3 s off the core in all
      });
  EXPECT_TRUE(stats.complete);
  EXPECT_FALSE(stats.hit_time_limit);
  EXPECT_EQ(streamed, 20u);
}

// A shutdown must not wait for another registration's search: a raised flag ends the wait for igraph.
TEST(CliqueSearch, AStopEndsTheWaitForIgraph) {
  LockHolder holder;
  StopFlag stop{false};
  std::size_t streamed = 0;
  auto queued = std::async(std::launch::async, [&] {
    return searchMaximalCliques(
        disjointTriangles(8), {}, [&](const int*, std::size_t) { ++streamed; }, &stop);
  });
  ASSERT_EQ(queued.wait_for(std::chrono::milliseconds(200)), std::future_status::timeout);
  const auto raised = std::chrono::steady_clock::now();
  stop = true;
  ASSERT_EQ(queued.wait_for(std::chrono::seconds(5)), std::future_status::ready);
  const double stop_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - raised).count();
  EXPECT_LT(stop_ms, 200.0) << "the stop waited for the other search";
  const CliqueSearchStats stats = queued.get();
  EXPECT_TRUE(stats.cancelled);
  EXPECT_FALSE(stats.complete);
  EXPECT_EQ(streamed, 0u);
}

}  // namespace
}  // namespace mac_registration
