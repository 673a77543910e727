#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <limits>
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
  kNoClique,               // no clique of min_clique_size found; clique_search_complete false when a
                           // bound (cliques.time_limit, max_cliques) cut the search off first (message says)
  kNoValidHypothesis,      // every clique was degenerate or no hypothesis scored above 0
  kTooFewInliers,          // the best transform has fewer than min_inliers inliers
  kInternalError,          // igraph failed; message carries its error
  kCancelled,              // the caller's StopFlag was raised before the registration finished
  kUnverified,             // a transform was found but the verification did not confirm it (see message)
};

const char* toString(RegistrationStatus status);

// Where the time of a registration went: wall-clock milliseconds per stage, in the order the stages run.
// One struct from the front end to the node's result message (RegistrationResult's time_*_ms fields):
// the front end fills its stages (FrontEndStats::times), the core its own (MacResult::times), and a
// registration from clouds adds the two (operator+=). Stages that did not run stay 0.
struct StageTimes {
  // The front end (mac_registration/features), both clouds together.
  double resolution_ms = 0.0;  // mean nearest-neighbour distance of the given clouds, when it is needed
  double downsample_ms = 0.0;  // voxel grid
  double normals_ms = 0.0;
  double features_ms = 0.0;  // FPFH
  double matching_ms = 0.0;  // descriptor search
  // The core.
  double graph_ms = 0.0;          // first-order graph
  double second_order_ms = 0.0;   // SOG weights
  double clique_search_ms = 0.0;  // igraph enumeration, excluding the selection it streams into and the wait
  // For igraph's process-wide lock while other registrations in the process searched (igraph is not
  // thread-safe): not counted in cliques.time_limit, and 0 for a registration that runs alone.
  double clique_wait_ms = 0.0;
  // Node-guided selection, filters, top-K: the time they added to the search's (on two or more threads
  // the selection runs beside the search, and only what it does not overlap counts here).
  double selection_ms = 0.0;
  double hypotheses_ms = 0.0;  // SVD per selected clique
  double evaluation_ms = 0.0;  // scoring every hypothesis on all correspondences
  double refinement_ms = 0.0;
  double verification_ms = 0.0;    // signals, alternatives and confidence (with a witness: its judging too)
  double fine_alignment_ms = 0.0;  // a witness's fine alignment of the pose (part of verification_ms)
  // From the start of the first stage timed here to the end of the last, what lies between them included
  // (the core's bookkeeping around its stages): at least the sum of the stages.
  double total_ms = 0.0;

  double frontEndMs() const { return resolution_ms + downsample_ms + normals_ms + features_ms + matching_ms; }
  // Every field, total_ms included: the times of stages that ran one after the other.
  StageTimes& operator+=(const StageTimes& other);
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
  std::size_t hypotheses = 0;          // non-degenerate transforms within the tilt prior
  std::size_t degenerate_cliques = 0;  // cliques whose points fix no rotation
  std::size_t tilted_hypotheses = 0;   // beyond evaluation.max_tilt_deg: never the answer, still rivals
  std::size_t inliers = 0;             // of the final transform
  int refinement_iterations = 0;
};

// A pose that competes with the reported one: what a caller needs to disambiguate (odometry, a particle
// filter, the next scan).
struct PoseAlternative {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double score = 0.0;         // evaluation metric, after refinement
  std::size_t inliers = 0;    // of the correspondences, at evaluation.inlier_threshold
  double score_ratio = 0.0;   // score / the reported transform's score
  double rotation_deg = 0.0;  // [deg] rotation between this pose and the reported one
  double displacement = 0.0;  // [m] RMS distance between the source points under the two poses
};

constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();

// The evidence the verification decided from (src/core/verification.hpp); NaN where a signal was not measured
// (no clouds given, verification off, or no transform to verify).
struct VerificationSignals {
  // From the correspondences. The best rival: the hypothesis at a clearly different pose (more than
  // verification.distinct_pose_factor x tau RMS away) that explains most of what the reported pose
  // leaves unexplained, scored on those correspondences alone.
  double rival_ratio = kNotMeasured;         // its score / the reported score; 0 = no rival
  double rival_rotation_deg = kNotMeasured;  // [deg] its rotation from the reported pose
  double rival_displacement = kNotMeasured;  // [m] its RMS displacement of the source points
  // [count] Inliers the reported pose would have if every target were paired with a random source (the
  // mean over permutations of the targets): what unrelated matches give at this pose by chance.
  double chance_inliers = kNotMeasured;
  // [nats] -ln of the expected number of hypotheses, of those tried, whose consensus is as large as the
  // reported one by chance (Poisson tail at chance_inliers, times the hypotheses scored): below ~0 a
  // consensus this large is what unrelated matches give.
  double chance_significance = kNotMeasured;
  // The shape of the inliers' source points, from the eigenvalues l1 >= l2 >= l3 of their covariance:
  // planarity l3 / l2 near 0 is a consensus on one plane (one wall matched onto another supports a turned
  // or slid pose as well as the right one), linearity l2 / l1 near 0 one along a line (measured, not
  // weighed: a lidar's inliers along a street are right poses too).
  double inlier_planarity = kNotMeasured;
  double inlier_linearity = kNotMeasured;
  // Planarity l3 / l2 of all the matched source points: the scene's own flatness (a road ahead of a car is
  // flat, a room is not), against which the inliers' planarity is judged.
  double scene_planarity = kNotMeasured;
  // [x tau] How far the fine alignment on the clouds (FineAlignment) moved the paired source keypoints from
  // the pose verified, RMS: a right pose is only polished (a fraction of tau), a near miss slides several tau
  // into the surfaces' own fit, and a pose in a wrong basin moves wherever that basin's walls lead it.
  double fine_alignment_move = kNotMeasured;
  // 1 where the fine alignment settled within its steps, 0 where it was still sliding (along a wall, out
  // of a wrong basin) when they ran out.
  double fine_alignment_converged = kNotMeasured;
  // The correspondences within tau at the fine alignment's pose per one within tau at the pose they gave:
  // a coarse pose the fine alignment polished keeps its consensus (about 1, above where the fine pose
  // explains more); a fit that slid elsewhere loses it.
  double fine_alignment_support = kNotMeasured;
  // From the clouds (front end only), on the keypoints, at tau = evaluation.inlier_threshold.
  double aligned_overlap = kNotMeasured;  // share of the aligned source within tau of the target
  // Of the aligned source keypoints in directions the target's sensor saw (its viewpoint), the share on
  // the target's surfaces (within tau).
  double seen_on_surface = kNotMeasured;
  // Of the aligned source keypoints on the target's surfaces, the share whose normal lies within 30 deg
  // of the target's there (either orientation): 13 % for surfaces meeting at random angles.
  double surface_agreement = kNotMeasured;
  // Share of keypoints lying more than tau in front of everything the other cloud's sensor saw in their
  // direction, in space it saw through; the larger of the two views (target seeing the aligned source,
  // source seeing the aligned target).
  double free_space_violation = kNotMeasured;
};

// One signal's share of the evidence the confidence sums: its log-odds term and, when it speaks against the
// pose, why.
struct EvidenceTerm {
  std::string signal;  // the VerificationSignals field
  double log_odds = 0.0;
  std::string reason;  // a sentence a user can act on; empty when the term is for the pose
};

// The fine alignment of a verified pose on the clouds: point-to-plane ICP of the source keypoints onto the
// target's keypoints and normals, each paired with its nearest target keypoint within tau, from the pose the
// correspondences gave. Offered by a witness that holds the clouds (PoseWitness::refine).
struct FineAlignment {
  bool ran = false;
  bool converged = false;  // its last step moved the paired points by less than a thousandth of tau
  int iterations = 0;
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();            // the pose it started from
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  // the pose it ended at
  double fitness = 0.0;        // share of the source keypoints paired at the end (within tau; of a large
                               // cloud's keypoints, every k-th is used: at most 5000)
  double rmse = 0.0;           // [m] RMS point-to-plane residual of those pairs
  double rotation_deg = 0.0;   // [deg] rotation between the two poses
  double translation_m = 0.0;  // [m] distance between their translations
  double displacement = 0.0;   // [m] RMS displacement of the paired source keypoints between the two poses
  // How certain T_target_source is, from the fit: the residual variance times the inverse of the
  // point-to-plane Gauss-Newton matrix at the final pose. The covariance of a small motion d in the source
  // frame, T_true = T_target_source * exp(d), d = (translation x, y, z [m], rotation about x, y, z [rad]):
  // the order and frame of a relative-pose edge in g2o or hdl_graph_slam (GTSAM's Pose3 puts the rotation
  // first). A direction the surfaces leave free (a corridor's length) has variance 1e6. README, "Using
  // the covariance".
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e6;
};

struct MacResult {
  bool success = false;
  RegistrationStatus status = RegistrationStatus::kInternalError;
  std::string message;                // why it failed, or a one-line summary on success
  std::vector<std::string> warnings;  // bounds that were hit and what was done about them
  // Maps source points into the target frame (as tf2's lookupTransform(target, source)). Identity, and
  // not to be used, unless success, or status kTooFewInliers or kUnverified (then the best transform found,
  // unverified). Where a fine alignment ran, the pose it ended at (fine_alignment.start is the one the
  // correspondences gave; the clouds judged both).
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  // The consensus of the correspondences' pose (fine_alignment.start where it ran).
  std::vector<int> inlier_indices;  // indices into the caller's correspondences
  double score = 0.0;               // evaluation metric
  // False when a bound (cliques.time_limit, cliques.max_cliques) stopped the enumeration, also when a
  // search of the graph pruned to its strongest nodes completed after it (a warning says which).
  bool clique_search_complete = true;
  bool graph_reduced = false;  // a size or density bound left correspondences out of the graph
  RegistrationCounters counters;
  StageTimes times;
  // How sure the verification is that T_target_source is right, in [0, 1]: success requires at least
  // verification.min_confidence. 0 when nothing was verified (no transform, or verification off).
  double confidence = 0.0;
  VerificationSignals verification;
  // The terms the confidence is the logistic function of, one per measured signal, in the order of the
  // signals' fields (empty when nothing was verified).
  std::vector<EvidenceTerm> evidence;
  FineAlignment fine_alignment;  // ran: false where no witness offered one (correspondences alone)
  // Distinct competing poses, best first (at most verification.max_alternatives), each refined.
  std::vector<PoseAlternative> alternatives;
};

// Whether T_target_source holds a transform the registration found: on success, and on the failures that
// still carry their best estimate (too few inliers, unverified). Otherwise it is the identity.
inline bool hasEstimate(const MacResult& result) {
  return result.success || result.status == RegistrationStatus::kTooFewInliers ||
         result.status == RegistrationStatus::kUnverified;
}

}  // namespace mac_registration
