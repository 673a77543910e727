#pragma once

// The verification stage: after refinement, is the transform right? MAC always returns its best
// hypothesis, and on a pair that does not overlap, or whose true consensus is too small to stand out, the
// best hypothesis is wrong with as many inliers as a right one elsewhere (measured: 58-150 inliers on
// 3DMatch FPFH sets without a single true correspondence). What separates right from wrong is whether the
// pose stands alone: a right pose collects the consensus of the correspondences and no pose far from it
// explains much of the rest; a wrong pose is one of several chance alignments of nearly equal score. With
// clouds, the aligned clouds themselves are a second, independent witness (core/pose_witness.hpp,
// features/cloud_verification), heard before the one decision.
//
// The signals combine into a confidence = 1 / (1 + exp(-L)), L a sum of evidence terms (log-odds), one per
// signal (verificationEvidence); BENCHMARKS.md has the labelled evaluation they were set on and the error
// rates at each verification.min_confidence.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "evaluation.hpp"
#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/pose_witness.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

// A hypothesis as the evaluation scored it.
struct ScoredHypothesis {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  HypothesisScore score;
};

// First and second moments of a point set: enough to measure how far apart two poses move it.
struct PointMoments {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  // E[s s^T]
};

PointMoments pointMoments(const Eigen::Matrix3Xd& points);

// [m] RMS over the points of |a s - b s|, in O(1) from the moments: how different two poses are where it
// matters, on the points they move (a rotation about the points' centre moves them less than one about a
// far origin).
double rmsDisplacement(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const PointMoments& moments);

// [count] The mean inlier count at T_target_source (residual < tau) over all pairings of the sources with
// the targets: sum over i, j of [|T s_i - t_j| < tau] / N. On the targets' neighbour grid (each source
// tested against the targets of the 27 cells around it), on num_threads threads (0 = OpenMP's default);
// the same count whatever num_threads.
double chanceInliers(const CorrespondenceSet& correspondences, const Eigen::Isometry3d& T_target_source,
                     double tau, int num_threads = 1);

// [nats] -ln(hypotheses x P(X >= inliers)), X Poisson with mean chance_inliers: how far the consensus
// stands above the best that chance gives among that many hypotheses (0 = one expected by chance).
double chanceSignificance(std::size_t inliers, double chance_inliers, std::size_t hypotheses);

// The correspondence signals of result.T_target_source (the refined best hypothesis, score result.score)
// against `hypotheses`, every scored hypothesis of the search: the best rival at a clearly different pose
// (more than distinct_pose_factor x tau RMS away), scored on the correspondences the reported pose leaves
// unexplained; the inliers chance would give at the pose; and up to max_alternatives distinct rivals,
// refined. Fills result.verification's correspondence signals and result.alternatives.
void measureCorrespondenceSignals(const CorrespondenceSet& correspondences,
                                  const std::vector<ScoredHypothesis>& hypotheses,
                                  const HypothesisEvaluator& evaluator, const MacParams& params,
                                  const StopFlag* stop, MacResult& result);

// The terms of the signals that were measured (NaN ones are left out), in the order of the fields.
std::vector<EvidenceTerm> verificationEvidence(const VerificationSignals& signals);

// The confidence in [0, 1] of these terms: the logistic function of their sum.
double confidenceOf(const std::vector<EvidenceTerm>& terms);

// Sets result.confidence from its signals and decides: a result that has a transform (success, or
// kUnverified) becomes kSuccess at or above params.min_confidence, else kUnverified, keeping its
// transform, with the reasons in its message. Other failures are left alone.
void decideVerification(const VerificationParams& params, MacResult& result);

// The witness's fine alignment from result.T_target_source, if it offers one, into result.fine_alignment,
// and how far it moved the pose, in units of `tau`, into result.verification.fine_alignment_move; timed in
// result.times.fine_alignment_ms.
void alignFinely(const PoseWitness& witness, double tau, MacResult& result);

// The signals `witness` measured (its non-NaN fields) into result.verification, and its warnings into
// result.warnings. Where result.fine_alignment moved the pose, the witness judges both poses: within the
// move term's free band each signal counts at the less favourable of the two, beyond it at the fine pose
// (the surfaces' agreement still at the less favourable).
void hearWitness(const PoseWitness& witness, MacResult& result);

// The verification stage of the core: measureCorrespondenceSignals(), the witness if any, then the one
// decideVerification() on all the evidence, timed in result.times.verification_ms. Nothing when
// verification is off or the result has no transform.
void verifyRegistration(const CorrespondenceSet& correspondences,
                        const std::vector<ScoredHypothesis>& hypotheses, const HypothesisEvaluator& evaluator,
                        const MacParams& params, const StopFlag* stop, const PoseWitness* witness,
                        MacResult& result);

}  // namespace mac_registration
