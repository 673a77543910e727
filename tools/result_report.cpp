#include "result_report.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "mac_registration/core/mac_registration.hpp"

namespace mac_registration {
namespace {

// "42.0 %" for a share, "-" for a signal that was not measured.
std::string shareText(double share) {
  if (std::isnan(share)) return "-";
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << 100.0 * share << " %";
  return text.str();
}

}  // namespace

void printVerification(std::ostream& out, const MacResult& r) {
  const VerificationSignals& s = r.verification;
  if (std::isnan(s.rival_ratio)) return;  // not verified
  out << std::fixed << std::setprecision(2) << "verification: confidence " << r.confidence << "; rival ratio "
      << s.rival_ratio;
  if (!std::isnan(s.rival_rotation_deg))
    out << std::setprecision(0) << " (a pose " << s.rival_rotation_deg << " deg, " << std::setprecision(2)
        << s.rival_displacement << " m away)";
  if (!std::isnan(s.chance_inliers))
    out << std::setprecision(1) << "; inliers by chance " << s.chance_inliers << " (significance "
        << s.chance_significance << " nats)";
  if (!std::isnan(s.inlier_planarity))
    out << std::setprecision(3) << "; inlier planarity " << s.inlier_planarity << ", linearity "
        << s.inlier_linearity;
  if (!std::isnan(s.aligned_overlap))
    out << "; aligned overlap " << shareText(s.aligned_overlap) << ", seen on surface "
        << shareText(s.seen_on_surface) << ", in free space " << shareText(s.free_space_violation);
  if (!std::isnan(s.surface_agreement)) out << ", along the surfaces " << shareText(s.surface_agreement);
  out << "\n";
  const FineAlignment& f = r.fine_alignment;
  if (f.ran)
    out << std::setprecision(2) << "fine alignment: " << f.iterations << " steps"
        << (f.converged ? "" : " (not converged)") << ", moved " << f.rotation_deg << " deg and "
        << f.displacement << " m (RMS, " << s.fine_alignment_move << " tau); " << shareText(f.fitness)
        << " of the source paired, residual " << std::setprecision(3) << f.rmse << " m; "
        << "the pose above\n";
  if (f.ran) {
    out << std::setprecision(4) << "covariance (source frame), standard deviations: x y z";
    for (int k = 0; k < 3; ++k) out << " " << std::sqrt(f.covariance(k, k));
    out << " m, rotation x y z";
    for (int k = 3; k < 6; ++k) out << " " << std::sqrt(f.covariance(k, k)) * 180.0 / M_PI;
    out << " deg\n";
  }
  for (std::size_t k = 0; k < r.alternatives.size(); ++k) {
    const PoseAlternative& a = r.alternatives[k];
    out << std::setprecision(2) << "alternative " << k + 1 << ": score " << a.score_ratio << " of the best, "
        << a.inliers << " inliers, " << std::setprecision(1) << a.rotation_deg << " deg and "
        << std::setprecision(2) << a.displacement << " m (RMS) away, T_target_source row-major:";
    out << std::setprecision(6);
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 4; ++col) out << " " << a.T_target_source.matrix()(row, col);
    out << " 0 0 0 1\n";
  }
  out.unsetf(std::ios::fixed);
}

void printResultSummary(std::ostream& out, const MacResult& r) {
  const auto& c = r.counters;
  const auto& t = r.times;
  out << "status: " << toString(r.status) << (r.success ? "" : " (FAILED)") << ": " << r.message << "\n";
  for (const auto& warning : r.warnings) out << "warning: " << warning << "\n";
  printVerification(out, r);
  out << "counters: correspondences " << c.correspondences << ", dropped non-finite " << c.dropped_non_finite
      << ", graph nodes " << c.graph_nodes << ", first-order edges " << c.first_order_edges
      << ", graph edges " << c.graph_edges << " (" << c.pruned_weak_edges << " weak pruned), cliques "
      << c.cliques << (r.clique_search_complete ? "" : " (search bounded)") << ", pruning rounds "
      << c.pruning_rounds << ", selected cliques " << c.selected_cliques << ", hypotheses " << c.hypotheses
      << ", degenerate cliques " << c.degenerate_cliques << ", tilted hypotheses " << c.tilted_hypotheses
      << ", inliers " << c.inliers << ", refinement iterations " << c.refinement_iterations << "\n";
  out << std::fixed << std::setprecision(2) << "time [ms]: graph " << t.graph_ms << ", second order "
      << t.second_order_ms << ", clique search " << t.clique_search_ms << ", selection " << t.selection_ms
      << ", hypotheses " << t.hypotheses_ms << ", evaluation " << t.evaluation_ms << ", refinement "
      << t.refinement_ms << ", verification " << t.verification_ms << ", total " << t.total_ms << "\n";
  out.unsetf(std::ios::fixed);
  out << "kernels: " << kernelsInUse() << "\n";
}

}  // namespace mac_registration
