#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace mac_registration {

// The values a numeric parameter accepts. Each parameter's range is written once: the core's below
// (macParameterRanges), the front end's and the ROS node's in the parameter table
// (config/parameter_table.hpp). The validators check against it, the table documents it, and every
// refusal is worded from it.
struct ParameterRange {
  // What 0 means when it lies outside [min, max] and is still accepted.
  enum class Zero {
    kPlain,  // nothing special: 0 is accepted only inside [min, max]
    kOff,    // the feature is off, or the bound lifted
    kAuto,   // a value derived from the data; only a cloud registration can derive it
  };

  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  // Whether the bound itself is refused. An infinite max is open (infinity refused) unless infinity means
  // something (orInfinity).
  bool min_open = false;
  bool max_open = true;
  Zero zero = Zero::kPlain;
  std::string zero_meaning;      // what 0 stands for, in a few words ("no bound"); shown as "(0 = ...)"
  std::string infinity_meaning;  // what inf stands for, where it is accepted
  std::string hint;              // why the bound, or the usual values; ends a refusal

  static ParameterRange atLeast(double min);  // [min, inf)
  static ParameterRange above(double min);    // (min, inf)
  static ParameterRange closed(double min, double max);
  static ParameterRange open(double min, double max);
  static ParameterRange openClosed(double min, double max);   // (min, max]
  ParameterRange orOff(std::string meaning) const;            // 0 accepted too: off
  ParameterRange orAuto(std::string meaning) const;           // 0 accepted too: derived from the data
  ParameterRange withZeroMeaning(std::string meaning) const;  // 0 is inside and means something
  ParameterRange orInfinity(std::string meaning) const;       // inf accepted too (above a finite min)
  ParameterRange withHint(std::string hint) const;

  // A value inside [min, max], or 0 where 0 means off or auto; never NaN.
  bool contains(double value) const;
  // The accepted values as a refusal says them: "in (0, 1)", ">= 1000 (0 = no bound)".
  std::string text() const;
};

// The one wording of a refusal: "KEY = VALUE [UNIT] is out of range: must be RANGE; HINT."
std::string outOfRangeMessage(const std::string& key, double value, const std::string& unit,
                              const ParameterRange& range);

// How the compatibility of two correspondences is scored from their rigidity residual
// d = | |s_i - s_j| - |t_i - t_j| |.
enum class CompatibilityScore {
  kGaussian,   // S = exp(-d^2 / (2 sigma^2)), the paper's Eq. 2 (sigma = d_cmp)
  kQuadratic,  // S = 1 - d^2 / tau^2, what the MAC authors use for KITTI and learned matchers
};

// Stage 1-2: compatibility graph.
struct GraphParams {
  CompatibilityScore score = CompatibilityScore::kGaussian;
  // d_cmp [m], > 0. The paper uses 10 x cloud resolution; correspondence-only callers give it in metres.
  // 0.05 suits 3DMatch-like indoor FPFH matches (sparse graph, full recall on the shipped real set).
  // A cloud registration takes 0 as auto: kGaussianSigmaVoxels x features.voxel_size.
  double gaussian_sigma = 0.05;
  // tau_g [m], > 0, for the quadratic score; with clouds 0 = auto (kQuadraticThresholdVoxels x voxel).
  double quadratic_threshold = 0.1;
  // t_cmp, in (0, 1): an edge exists where S >= t_cmp. Higher = sparser graph. Paper default 0.99.
  double t_cmp = 0.99;
  // Second-order graph (SOG, paper Eq. 4) instead of the first-order one. The paper's default.
  bool second_order = true;
  // Time bound of the first-order pass, O(N^2) pair tests [correspondences], 0 = no bound, else >= 1000:
  // above it, the graph is built on this many of them, evenly spaced in input order (evaluation and
  // refinement still use all). 50 000 (1.25e9 pairs) take ~0.6 s on 2 cores; the inlier ratio of the
  // subset is that of the whole set, so large easy sets stay easy. The result records it.
  std::size_t max_correspondences = 50000;
  // Memory bound: most first-order edges kept [count], >= 1000. A denser graph is rebuilt on the
  // sqrt(2 max_edges) correspondences of highest degree (counted over every pair; the result records it).
  std::size_t max_edges = 4000000;
  // Time bound of the second-order weights [multiply-adds], >= 1e5. A graph whose SOG would cost more is
  // reduced to its highest-degree nodes first (the result records it).
  double max_second_order_work = 3e8;
  // Dense-graph pruning [mean degree], 0 = never, else >= 1: when the graph searched for cliques has a
  // higher mean degree, its edges below Otsu's threshold of the edge weights are removed first. Dense
  // graphs come from many outliers that are compatible by chance; their edges have few common neighbours
  // and light second-order weights, while a consensus set's edges are heavy. (The MAC authors' code prunes
  // dense graphs too, by clustering coefficient.) The same bound picks the second-order weights: a
  // first-order graph above it gets them estimated from common-neighbour counts, within a factor t_cmp^2
  // of Eq. 4's sums (the counted second-order weights), a sparser one the exact sums. 20 keeps every result
  // of the benchmark sets that 50 gave and cuts the chance cliques of real FPFH matches (whose second-order
  // graphs have mean degrees of 20-50); see doc/decisions/dense-mean-degree.md.
  double dense_mean_degree = 20.0;
};

// Stage 3: maximal clique search.
struct CliqueSearchParams {
  // Smallest clique reported [nodes], >= 3 (three points fix a rigid transform). 4 suits outdoor lidar.
  int min_clique_size = 3;
  // Largest clique reported [nodes], 0 = no cap, else >= min_clique_size.
  int max_clique_size = 0;
  // Most cliques one search may stream [count], >= 1. On clean, high-inlier data the number of maximal
  // cliques explodes; when the bound is hit the graph is pruned to its strongest nodes and searched again.
  std::size_t max_cliques = 200000;
  // Largest degeneracy searched [core number], 0 = no bound, else >= 2. A dense consensus set (many clean
  // inliers) forms a near-clique of hundreds of nodes, where the enumeration spends seconds inside igraph
  // without reporting a clique. Above the bound, the nodes of the dense cores are thinned to the
  // max_degeneracy strongest before the search: any clique of them is an equally good hypothesis, and
  // evaluation and refinement still use every correspondence.
  int max_degeneracy = 64;
  // Budget for all searches together [s], > 0, in CPU time of the thread that searches: the wait for
  // igraph's process-wide lock (another registration's search) and the time other work on the machine
  // takes the core from it do not count, so that a registration gives the same result under load as alone.
  // On an idle machine it is wall-clock time; under load the search may take longer by the wall clock.
  double time_limit = 2.0;
  // How often a bounded search may prune and retry, in [0, 10].
  int max_pruning_rounds = 3;
  // Fraction of the nodes kept at each pruning round, in (0, 1).
  double pruning_keep_fraction = 0.5;
};

// Stage 4: node-guided clique selection.
struct SelectionParams {
  // Normal-consistency filter (paper Sec. 3.3); needs normals in the correspondences.
  bool normal_consistency = false;
  // t_alpha, in (0, 1]: pairs must satisfy |sin a_s - sin a_t| < t_alpha.
  double normal_consistency_threshold = 0.1;
  // Keep the K heaviest selected cliques [count], 0 = all.
  std::size_t top_k = 0;
};

// Stage 5: hypotheses.
enum class HypothesisWeighting {
  kEqual,        // instance-equal SVD, the paper's default
  kEigenvector,  // weights = principal eigenvector of the SOG weight matrix (paper's weighted SVD)
};

struct HypothesisParams {
  HypothesisWeighting weighting = HypothesisWeighting::kEqual;
};

// Stage 6: evaluation.
enum class ScoreMetric {
  kMAE,          // sum over inliers of (tau - r) / tau, the paper's default
  kMSE,          // sum over inliers of (tau - r)^2 / tau^2
  kInlierCount,  // number of inliers
};

struct EvaluationParams {
  ScoreMetric metric = ScoreMetric::kMAE;
  // tau [m], > 0: a correspondence is an inlier when |R s + t - t_target| < tau. 0.1 indoors, 0.6 KITTI.
  // A cloud registration takes 0 as auto: kInlierThresholdVoxels x features.voxel_size.
  double inlier_threshold = 0.1;
  // Fewest inliers for the result to count as a success [count], >= 3.
  std::size_t min_inliers = 3;
  // Largest angle a pose may turn the source's z axis away from the target's [deg], in (0, 180]; 180 =
  // no prior. A ground robot's frames have z up (REP-103): two of its scans differ by the terrain's slope
  // and the body's roll and pitch, so a hypothesis that tips the source over is not taken, however many
  // correspondences it explains (repeated structure and mirror images often give such consensus).
  double max_tilt_deg = 180.0;
};

// Stage 7: refinement.
struct RefinementParams {
  bool enabled = true;
  // Most reweighted-SVD rounds [count], in [1, 100].
  int max_iterations = 20;
};

// Stage 8: verification, after refinement: is the transform right? Decides success from evidence that
// separates right from wrong poses (see src/core/verification.hpp), not from the inlier count alone.
struct VerificationParams {
  // Off: success as before (min_inliers alone), no confidence, no alternatives.
  bool enabled = true;
  // Fewest confidence for a success, in [0, 1]; below it the result is kUnverified and carries its best
  // transform marked as such. 0 accepts every transform (the signals are still measured). What a value
  // means is measured, not assumed: BENCHMARKS.md lists the right poses kept and the wrong ones accepted
  // at each value (0.5, with clouds: the whole 3DMatch benchmark of four scenes 88.6 % recall, 6 of 931
  // successes wrong and none grossly; none of the verification's 95 negatives accepted).
  double min_confidence = 0.5;
  // With a witness that holds the clouds: align the pose finely on them (FineAlignment) before deciding,
  // weigh how far that moved it, and report the fine pose.
  bool fine_alignment = true;
  // [x evaluation.inlier_threshold], > 0: a pose counts as a rival when it moves the source points, RMS,
  // more than this many inlier thresholds away from the reported pose.
  double distinct_pose_factor = 5.0;
  // Rival poses reported with the result [count], in [0, 10]; the best rival is measured even at 0.
  std::size_t max_alternatives = 3;
};

struct MacParams {
  GraphParams graph;
  CliqueSearchParams cliques;
  SelectionParams selection;
  HypothesisParams hypotheses;
  EvaluationParams evaluation;
  RefinementParams refinement;
  VerificationParams verification;
  // Worker threads for the parallel stages, 0 = OpenMP's default. Results do not depend on it.
  int num_threads = 0;
};

// A numeric parameter of MacParams: its key (as in the presets and the parameter table), unit and range.
// The parameter table takes both from here, so that the core, which registers correspondences without
// the table, checks the same ranges the table documents.
struct MacParameterRange {
  std::string key;
  std::string unit;  // "m", "s", "nodes", ...; empty when the value has none
  ParameterRange range;
  double (*value)(const MacParams&);
};

// Every numeric parameter of MacParams, in the order of the presets' sections.
const std::vector<MacParameterRange>& macParameterRanges();

// The entry of `key`, or nullptr.
const MacParameterRange* findMacParameterRange(const std::string& key);

// Whether a 0 that means auto passes: the core alone cannot derive it (it sees correspondences only), a
// cloud registration derives it from the voxel size before the core runs.
enum class AutoValues { kRefused, kAccepted };

// Every problem with the parameters, each as a sentence naming the parameter, its value and the allowed
// range: the ranges of macParameterRanges(), then the rules between parameters. Empty when the
// parameters are usable.
std::vector<std::string> validateParams(const MacParams& params, AutoValues autos = AutoValues::kRefused);

}  // namespace mac_registration
