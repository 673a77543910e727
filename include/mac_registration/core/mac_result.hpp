#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mac_registration {

// The values are part of the ROS interface (RegistrationResult.status): append, never renumber.
enum class RegistrationStatus : std::uint8_t {
  kSuccess = 0,
  kInvalidParameters,      // validateParams() refused the parameters; message lists why
  kInvalidInput,           // e.g. source and target counts differ
  kTooFewCorrespondences,  // fewer than 3 usable (finite) correspondences
  kEmptyGraph,             // no compatible pair (or, for SOG, no compatible triangle)
  kNoClique,               // no clique of min_clique_size
  kNoValidHypothesis,      // every clique was degenerate or no hypothesis scored above 0
  kTooFewInliers,          // the best transform has fewer than min_inliers inliers
  kInternalError,          // igraph failed; message carries its error
  kCancelled,              // the caller's StopFlag was raised before the registration finished
};

const char* toString(RegistrationStatus status);

struct StageTimes {               // wall-clock milliseconds
  double graph_ms = 0.0;          // first-order graph
  double second_order_ms = 0.0;   // SOG weights
  double clique_search_ms = 0.0;  // igraph enumeration, excluding the selection it streams into
  double selection_ms = 0.0;      // node-guided selection, filters, top-K
  double hypotheses_ms = 0.0;     // SVD per selected clique
  double evaluation_ms = 0.0;     // scoring every hypothesis on all correspondences
  double refinement_ms = 0.0;
  double total_ms = 0.0;
};

struct RegistrationCounters {
  std::size_t correspondences = 0;     // given
  std::size_t dropped_non_finite = 0;  // with a NaN/Inf coordinate, not used
  std::size_t graph_nodes = 0;         // correspondences the graph was built on
  std::size_t first_order_edges = 0;
  std::size_t graph_edges = 0;         // edges searched for cliques (SOG when enabled)
  std::size_t pruned_weak_edges = 0;   // removed by dense-graph pruning
  std::size_t cliques = 0;             // maximal cliques enumerated
  int degeneracy = 0;                  // of the graph searched for cliques
  std::size_t thinned_nodes = 0;       // left out of the clique search by cliques.max_degeneracy
  int pruning_rounds = 0;              // clique searches repeated on a pruned graph
  std::size_t selected_cliques = 0;    // after node-guided selection and filters
  std::size_t hypotheses = 0;          // non-degenerate transforms scored
  std::size_t degenerate_cliques = 0;  // cliques whose points fix no rotation
  std::size_t inliers = 0;             // of the final transform
  int refinement_iterations = 0;
};

struct MacResult {
  bool success = false;
  RegistrationStatus status = RegistrationStatus::kInternalError;
  std::string message;                // why it failed, or a one-line summary on success
  std::vector<std::string> warnings;  // bounds that were hit and what was done about them
  // Maps source points into the target frame (as tf2's lookupTransform(target, source)). Identity, and
  // not to be used, unless success or status == kTooFewInliers (then the best transform found).
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  std::vector<int> inlier_indices;     // indices into the caller's correspondences
  double score = 0.0;                  // evaluation metric of T_target_source
  bool clique_search_complete = true;  // false when a bound stopped the enumeration
  bool graph_reduced = false;          // a size or density bound left correspondences out of the graph
  RegistrationCounters counters;
  StageTimes times;
};

}  // namespace mac_registration
