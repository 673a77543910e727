#include "mac_registration/core/parameters.hpp"

#include <cmath>
#include <sstream>

namespace mac_registration {
namespace {

class Checker {
 public:
  void require(bool ok, const std::string& name, double value, const std::string& allowed) {
    if (ok) return;
    std::ostringstream text;
    text << name << " = " << value << " is out of range: must be " << allowed << ".";
    problems_.push_back(text.str());
  }
  void positive(const std::string& name, double value) {
    require(std::isfinite(value) && value > 0.0, name, value, "> 0");
  }
  // A distance that a cloud registration derives from features.voxel_size when it is 0 (auto): the core
  // sees only correspondences, so here it must be a distance.
  void distance(const std::string& name, double value) {
    require(std::isfinite(value) && value > 0.0, name, value,
            "> 0 (0 = auto, derived from features.voxel_size, applies to clouds only: give the distance in "
            "metres to register correspondences)");
  }
  std::vector<std::string> problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

}  // namespace

std::vector<std::string> validateParams(const MacParams& p) {
  Checker check;
  check.distance("graph.gaussian_sigma [m]", p.graph.gaussian_sigma);
  check.distance("graph.quadratic_threshold [m]", p.graph.quadratic_threshold);
  check.require(p.graph.t_cmp > 0.0 && p.graph.t_cmp < 1.0, "graph.t_cmp", p.graph.t_cmp,
                "in (0, 1); 0.99 is the paper's default, lower it for few or very noisy correspondences");
  check.require(p.graph.max_correspondences == 0 || p.graph.max_correspondences >= 1000,
                "graph.max_correspondences", double(p.graph.max_correspondences), "0 (no bound) or >= 1000");
  check.require(p.graph.max_edges >= 1000, "graph.max_edges", double(p.graph.max_edges), ">= 1000");
  check.require(p.graph.max_second_order_work >= 1e5, "graph.max_second_order_work",
                p.graph.max_second_order_work, ">= 1e5");

  check.require(p.graph.dense_mean_degree == 0.0 || p.graph.dense_mean_degree >= 1.0,
                "graph.dense_mean_degree", p.graph.dense_mean_degree, "0 (never prune) or >= 1");
  check.require(p.cliques.min_clique_size >= 3, "cliques.min_clique_size", p.cliques.min_clique_size,
                ">= 3 (three points are needed for a rigid transform)");
  check.require(p.cliques.max_clique_size == 0 || p.cliques.max_clique_size >= p.cliques.min_clique_size,
                "cliques.max_clique_size", p.cliques.max_clique_size,
                "0 (no cap) or >= cliques.min_clique_size");
  check.require(p.cliques.max_degeneracy == 0 || p.cliques.max_degeneracy >= 2, "cliques.max_degeneracy",
                p.cliques.max_degeneracy, "0 (no bound) or >= 2");
  check.require(p.cliques.max_cliques >= 1, "cliques.max_cliques", double(p.cliques.max_cliques), ">= 1");
  check.positive("cliques.time_limit [s]", p.cliques.time_limit);
  check.require(p.cliques.max_pruning_rounds >= 0 && p.cliques.max_pruning_rounds <= 10,
                "cliques.max_pruning_rounds", p.cliques.max_pruning_rounds, "in [0, 10]");
  check.require(p.cliques.pruning_keep_fraction > 0.0 && p.cliques.pruning_keep_fraction < 1.0,
                "cliques.pruning_keep_fraction", p.cliques.pruning_keep_fraction, "in (0, 1)");

  check.require(
      p.selection.normal_consistency_threshold > 0.0 && p.selection.normal_consistency_threshold <= 1.0,
      "selection.normal_consistency_threshold", p.selection.normal_consistency_threshold, "in (0, 1]");

  check.distance("evaluation.inlier_threshold [m]", p.evaluation.inlier_threshold);
  check.require(p.evaluation.min_inliers >= 3, "evaluation.min_inliers", double(p.evaluation.min_inliers),
                ">= 3");

  check.require(p.refinement.max_iterations >= 1 && p.refinement.max_iterations <= 100,
                "refinement.max_iterations", p.refinement.max_iterations, "in [1, 100]");
  check.require(p.verification.min_confidence >= 0.0 && p.verification.min_confidence <= 1.0,
                "verification.min_confidence", p.verification.min_confidence, "in [0, 1]");
  check.positive("verification.distinct_pose_factor [x evaluation.inlier_threshold]",
                 p.verification.distinct_pose_factor);
  check.require(p.verification.max_alternatives <= 10, "verification.max_alternatives",
                double(p.verification.max_alternatives), "in [0, 10]");
  check.require(p.num_threads >= 0, "num_threads", p.num_threads, ">= 0 (0 = OpenMP's default)");
  return check.problems();
}

}  // namespace mac_registration
