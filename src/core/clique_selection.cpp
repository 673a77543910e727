#include "clique_selection.hpp"

#include <Eigen/Geometry>
#include <algorithm>

namespace mac_registration {

double cliqueWeight(const CompatibilityGraph& graph, const int* nodes, std::size_t size) {
  double weight = 0.0;
  for (std::size_t a = 0; a + 1 < size; ++a) {
    // Both lists are ascending, so each lookup starts where the previous one ended.
    auto it = graph.neighbours.begin() + graph.offsets[nodes[a]];
    const auto last = graph.neighbours.begin() + graph.offsets[nodes[a] + 1];
    for (std::size_t b = a + 1; b < size; ++b) {
      it = std::lower_bound(it, last, nodes[b]);
      if (it == last) break;
      if (*it == nodes[b]) weight += graph.weights[it - graph.neighbours.begin()];
    }
  }
  return weight;
}

CliqueWeightCache::CliqueWeightCache(const CompatibilityGraph& graph, int capacity)
    : graph_(graph),
      capacity_(std::max(capacity, 1)),
      local_of_node_(graph.num_nodes, -1),
      matrix_(static_cast<std::size_t>(capacity_) * capacity_, 0.0f) {
  node_of_local_.reserve(capacity_);
}

void CliqueWeightCache::clear() {
  for (int node : node_of_local_) local_of_node_[node] = -1;
  node_of_local_.clear();
}

// Only the entries between the new node and the nodes already in the matrix are written. The others may
// hold weights from before a clear(), but a clique reads only pairs of its own nodes, which are all edges,
// and each edge's two entries were written when the later of its nodes came in.
int CliqueWeightCache::add(int node) {
  const int local = static_cast<int>(node_of_local_.size());
  local_of_node_[node] = local;
  node_of_local_.push_back(node);
  const auto begin = graph_.neighbours.begin() + graph_.offsets[node];
  const auto end = graph_.neighbours.begin() + graph_.offsets[node + 1];
  const auto set = [&](int other, float weight) {
    matrix_[static_cast<std::size_t>(local) * capacity_ + other] = weight;
    matrix_[static_cast<std::size_t>(other) * capacity_ + local] = weight;
  };
  // A hub's list may be many times longer than the matrix is full: look the cached nodes up in it instead.
  if (end - begin > 8 * static_cast<std::ptrdiff_t>(local)) {
    for (int other = 0; other < local; ++other) {
      const auto it = std::lower_bound(begin, end, node_of_local_[other]);
      if (it != end && *it == node_of_local_[other])
        set(other, graph_.weights[it - graph_.neighbours.begin()]);
    }
  } else {
    for (auto it = begin; it != end; ++it) {
      const int other = local_of_node_[*it];
      if (other >= 0 && other != local) set(other, graph_.weights[it - graph_.neighbours.begin()]);
    }
  }
  return local;
}

double CliqueWeightCache::weight(const int* nodes, std::size_t size) {
  if (size > static_cast<std::size_t>(capacity_)) return cliqueWeight(graph_, nodes, size);
  std::size_t fresh = 0;
  for (std::size_t k = 0; k < size; ++k) fresh += local_of_node_[nodes[k]] < 0;
  if (node_of_local_.size() + fresh > static_cast<std::size_t>(capacity_)) clear();
  clique_locals_.resize(size);
  for (std::size_t k = 0; k < size; ++k) {
    const int local = local_of_node_[nodes[k]];
    clique_locals_[k] = local >= 0 ? local : add(nodes[k]);
  }
  // The pairs in cliqueWeight's order, each float added to the double sum: the same rounding.
  double weight = 0.0;
  for (std::size_t a = 0; a + 1 < size; ++a) {
    const float* row = &matrix_[static_cast<std::size_t>(clique_locals_[a]) * capacity_];
    for (std::size_t b = a + 1; b < size; ++b) weight += row[clique_locals_[b]];
  }
  return weight;
}

NodeGuidedSelector::NodeGuidedSelector(const CompatibilityGraph& graph)
    : weights_(graph), slot_of_node_(graph.num_nodes, -1), weight_of_node_(graph.num_nodes, 0.0) {}

void NodeGuidedSelector::offer(const int* nodes, std::size_t size) {
  const double weight = weights_.weight(nodes, size);
  int slot = -1;
  for (std::size_t k = 0; k < size; ++k) {
    const int node = nodes[k];
    if (slot_of_node_[node] != -1 && weight <= weight_of_node_[node]) continue;
    if (slot == -1) slot = store(nodes, size, weight);
    if (slot_of_node_[node] != -1) release(slot_of_node_[node]);
    slot_of_node_[node] = slot;
    weight_of_node_[node] = weight;
    ++slot_users_[slot];
  }
}

int NodeGuidedSelector::store(const int* nodes, std::size_t size, double weight) {
  int slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<int>(slots_.size());
    slots_.emplace_back();
    slot_users_.push_back(0);
  }
  slots_[slot].nodes.assign(nodes, nodes + size);
  slots_[slot].weight = weight;
  slot_users_[slot] = 0;
  return slot;
}

void NodeGuidedSelector::release(int slot) {
  if (--slot_users_[slot] > 0) return;
  slots_[slot].nodes = {};
  free_slots_.push_back(slot);
}

std::vector<SelectedClique> NodeGuidedSelector::selected() const {
  std::vector<SelectedClique> result;
  std::vector<char> emitted(slots_.size(), 0);
  for (int slot : slot_of_node_) {
    if (slot == -1 || emitted[slot]) continue;
    emitted[slot] = 1;
    result.push_back(slots_[slot]);
  }
  return result;
}

StreamedSelection::StreamedSelection(const CompatibilityGraph& graph, bool concurrent) : selector_(graph) {
  if (concurrent) worker_ = std::thread([this] { work(); });
}

StreamedSelection::~StreamedSelection() { stopWorker(); }

void StreamedSelection::add(const int* nodes, std::size_t size) {
  filling_.nodes.insert(filling_.nodes.end(), nodes, nodes + size);
  filling_.ends.push_back(filling_.nodes.size());
  if (filling_.ends.size() == kBatch) handOver();
}

void StreamedSelection::finish() {
  if (!filling_.ends.empty()) handOver();
  const auto start = std::chrono::steady_clock::now();
  stopWorker();
  waited_ += std::chrono::steady_clock::now() - start;
  if (error_) std::rethrow_exception(error_);
}

double StreamedSelection::waitedMilliseconds() const {
  return std::chrono::duration<double, std::milli>(waited_).count();
}

void StreamedSelection::offer(const Batch& batch) {
  std::size_t begin = 0;
  for (const std::size_t end : batch.ends) {
    selector_.offer(batch.nodes.data() + begin, end - begin);
    begin = end;
  }
}

// Inline, the batch is offered here (its time is the selection's); else it waits for the worker to have
// taken the previous batch, and swaps the full one in for the emptied one the worker left.
void StreamedSelection::handOver() {
  const auto start = std::chrono::steady_clock::now();
  if (!worker_.joinable()) {
    offer(filling_);
  } else {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return !handed_full_; });
    if (error_) std::rethrow_exception(error_);
    std::swap(filling_, handed_);
    handed_full_ = true;
    changed_.notify_all();
  }
  filling_.nodes.clear();
  filling_.ends.clear();
  waited_ += std::chrono::steady_clock::now() - start;
}

void StreamedSelection::work() {
  Batch working;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return handed_full_ || finished_; });
      if (!handed_full_) return;
      std::swap(working, handed_);
      handed_full_ = false;
      changed_.notify_all();
    }
    try {
      if (!error_) offer(working);
    } catch (...) {
      // Read by the search's thread only under the lock, after a hand-over or the join.
      std::lock_guard<std::mutex> lock(mutex_);
      error_ = std::current_exception();
    }
    working.nodes.clear();
    working.ends.clear();
  }
}

void StreamedSelection::stopWorker() {
  if (!worker_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finished_ = true;
    changed_.notify_all();
  }
  worker_.join();
}

std::vector<SelectedClique> normalConsistentCliques(const std::vector<SelectedClique>& cliques,
                                                    const CorrespondenceSet& c, double threshold,
                                                    const StopFlag* stop) {
  const auto sine = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return a.cross(b).norm() / std::max(a.norm() * b.norm(), 1e-12);
  };
  const auto consistent = [&](int i, int j) {
    const double sin_s = sine(c.source_normals.col(i), c.source_normals.col(j));
    const double sin_t = sine(c.target_normals.col(i), c.target_normals.col(j));
    return std::abs(sin_s - sin_t) < threshold;
  };
  std::vector<SelectedClique> kept;
  for (const auto& clique : cliques) {
    if (stopRequested(stop)) break;
    bool ok = true;
    for (std::size_t a = 0; ok && a < clique.nodes.size(); ++a) {
      for (std::size_t b = a + 1; ok && b < clique.nodes.size(); ++b)
        ok = consistent(clique.nodes[a], clique.nodes[b]);
    }
    if (ok) kept.push_back(clique);
  }
  return kept;
}

std::vector<SelectedClique> heaviestCliques(std::vector<SelectedClique> cliques, std::size_t k) {
  std::stable_sort(cliques.begin(), cliques.end(),
                   [](const SelectedClique& a, const SelectedClique& b) { return a.weight > b.weight; });
  if (k > 0 && cliques.size() > k) cliques.resize(k);
  return cliques;
}

}  // namespace mac_registration
