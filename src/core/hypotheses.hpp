#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "compatibility_graph.hpp"
#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

// Least-squares rigid transform mapping source onto target over the given correspondences (Kabsch/SVD,
// weighted centroids and covariance when weights are given, indexed by correspondence). A reflection
// (det < 0) is turned into the nearest rotation by flipping the last singular vector. Returns nothing when
// the points do not fix a rotation: fewer than three, all equal, or collinear (second singular value of
// the cross-covariance below 1e-6 of the first), or a non-positive total weight.
std::optional<Eigen::Isometry3d> estimateRigidTransform(const CorrespondenceSet& correspondences,
                                                        const std::vector<int>& indices,
                                                        const std::vector<double>& weights = {});

// Principal eigenvector of the graph's weight matrix by power iteration, scaled to max 1: the paper's
// correspondence weights for weighted SVD. Nodes outside every edge get weight 0. A raised `stop` ends the
// iteration early (the caller checks the flag before using the weights).
std::vector<double> principalEigenvector(const CompatibilityGraph& graph, int iterations = 50,
                                         const StopFlag* stop = nullptr);

}  // namespace mac_registration
