#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "compatibility_graph.hpp"
#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

struct SelectedClique {
  std::vector<int> nodes;  // ascending correspondence indices
  double weight = 0.0;     // sum of the graph's edge weights inside the clique
};

// Sum of the edge weights among `nodes` (ascending), the clique weight of the paper's Sec. 3.3.
double cliqueWeight(const CompatibilityGraph& graph, const int* nodes, std::size_t size);

// cliqueWeight(), the same sums bit for bit, from a dense matrix of the weights among the nodes of recent
// cliques. The search streams the cliques of one neighbourhood after another, so consecutive cliques share
// most of their nodes: each node's row is filled once from its neighbour list, and a clique of k nodes then
// costs k(k-1)/2 loads instead of as many binary searches in lists of hundreds (a lidar graph's dense core:
// cliques of ~40 nodes, 8 us each by binary search). The matrix holds `capacity` nodes; a clique that brings
// more new nodes than there is room for starts it afresh.
class CliqueWeightCache {
 public:
  // capacity [nodes], >= 1: 256 keeps the matrix at 256 kB.
  explicit CliqueWeightCache(const CompatibilityGraph& graph, int capacity = 256);

  // `nodes`: ascending, and a clique of the graph (for any other set, use cliqueWeight).
  double weight(const int* nodes, std::size_t size);

 private:
  void clear();
  int add(int node);

  const CompatibilityGraph& graph_;
  int capacity_;
  std::vector<int> local_of_node_;  // -1 where a node is not in the matrix
  std::vector<int> node_of_local_;
  std::vector<float> matrix_;  // capacity_ x capacity_, row-major; meaningful for edges between cached nodes
  std::vector<int> clique_locals_;
};

// Node-guided clique selection (paper Sec. 3.3): each node keeps the heaviest clique that contains it
// (strictly heavier replaces, so the first found wins ties). Cliques are offered one at a time as the search
// streams them; only cliques some node still keeps are stored, so memory is bounded by N cliques.
class NodeGuidedSelector {
 public:
  explicit NodeGuidedSelector(const CompatibilityGraph& graph);

  void offer(const int* nodes, std::size_t size);

  // The distinct kept cliques, ordered by the lowest node that keeps them.
  std::vector<SelectedClique> selected() const;

 private:
  int store(const int* nodes, std::size_t size, double weight);
  void release(int slot);

  CliqueWeightCache weights_;
  std::vector<int> slot_of_node_;  // -1 where a node is in no clique yet
  std::vector<double> weight_of_node_;
  std::vector<SelectedClique> slots_;
  std::vector<int> slot_users_;
  std::vector<int> free_slots_;
};

// Offers the cliques a search streams to a NodeGuidedSelector in batches, in the order of the search.
// With `concurrent`, the batches are offered on a thread of its own while the search goes on: the search's
// thread hands a full batch over and fills the next, and the selector sees the same cliques in the same
// order, so the selection is the same either way. An exception of the selector comes back out of add() or
// finish().
class StreamedSelection {
 public:
  StreamedSelection(const CompatibilityGraph& graph, bool concurrent);
  ~StreamedSelection();
  StreamedSelection(const StreamedSelection&) = delete;
  StreamedSelection& operator=(const StreamedSelection&) = delete;

  void add(const int* nodes, std::size_t size);
  // Offers what is left and waits for the selector; call before selector().
  void finish();
  const NodeGuidedSelector& selector() const { return selector_; }
  // [ms] the search's thread spent offering cliques or waiting for the selector's thread: the selection's
  // time not overlapped with the search.
  double waitedMilliseconds() const;

 private:
  struct Batch {
    std::vector<int> nodes;
    std::vector<std::size_t> ends;
  };
  static constexpr std::size_t kBatch = 512;  // cliques a batch

  void offer(const Batch& batch);
  void handOver();
  void work();
  void stopWorker();

  NodeGuidedSelector selector_;
  Batch filling_, handed_;
  bool handed_full_ = false, finished_ = false;
  std::exception_ptr error_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::thread worker_;
  std::chrono::steady_clock::duration waited_{0};
};

// Keeps the cliques whose every pair of correspondences is normal-consistent (paper Eq. 5):
// |sin a_s - sin a_t| < threshold, a_s the angle between the two source normals, a_t between the target ones.
// A raised `stop` ends the filter early with the cliques checked so far.
std::vector<SelectedClique> normalConsistentCliques(const std::vector<SelectedClique>& cliques,
                                                    const CorrespondenceSet& correspondences,
                                                    double threshold, const StopFlag* stop = nullptr);

// The k heaviest cliques (all when k == 0), heaviest first; equal weights keep their order.
std::vector<SelectedClique> heaviestCliques(std::vector<SelectedClique> cliques, std::size_t k);

}  // namespace mac_registration
