#include "result_report.hpp"

#include <iomanip>

namespace mac_registration {

void printResultSummary(std::ostream& out, const MacResult& r) {
  const auto& c = r.counters;
  const auto& t = r.times;
  out << "status: " << toString(r.status) << (r.success ? "" : " (FAILED)") << ": " << r.message << "\n";
  for (const auto& warning : r.warnings) out << "warning: " << warning << "\n";
  out << "counters: correspondences " << c.correspondences << ", dropped non-finite " << c.dropped_non_finite
      << ", graph nodes " << c.graph_nodes << ", first-order edges " << c.first_order_edges
      << ", graph edges " << c.graph_edges << " (" << c.pruned_weak_edges << " weak pruned), cliques "
      << c.cliques << (r.clique_search_complete ? "" : " (search bounded)") << ", pruning rounds "
      << c.pruning_rounds << ", selected cliques " << c.selected_cliques << ", hypotheses " << c.hypotheses
      << ", degenerate cliques " << c.degenerate_cliques << ", inliers " << c.inliers
      << ", refinement iterations " << c.refinement_iterations << "\n";
  out << std::fixed << std::setprecision(2) << "time [ms]: graph " << t.graph_ms << ", second order "
      << t.second_order_ms << ", clique search " << t.clique_search_ms << ", selection " << t.selection_ms
      << ", hypotheses " << t.hypotheses_ms << ", evaluation " << t.evaluation_ms << ", refinement "
      << t.refinement_ms << ", total " << t.total_ms << "\n";
  out.unsetf(std::ios::fixed);
}

}  // namespace mac_registration
