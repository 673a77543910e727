#include "ransac_baseline.hpp"

#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/correspondence_rejection_sample_consensus.h>

#include <chrono>
#include <cmath>
#include <exception>
#include <string>

namespace mac_registration {

MacResult registerCorrespondencesRansac(const CorrespondenceSet& correspondences,
                                        const RansacParams& params) {
  const auto start = std::chrono::steady_clock::now();
  MacResult result;
  result.counters.correspondences = correspondences.size();
  const auto finish = [&](RegistrationStatus status, const std::string& message) {
    result.status = status;
    result.success = status == RegistrationStatus::kSuccess;
    result.message = message;
    result.times.total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  if (!(params.inlier_threshold > 0.0) || params.max_iterations < 1 || params.min_inliers < 3)
    return finish(RegistrationStatus::kInvalidParameters,
                  "RANSAC needs inlier_threshold > 0, max_iterations >= 1 and min_inliers >= 3");
  SanitizedCorrespondences sane;
  try {
    sane = sanitizeCorrespondences(correspondences);
  } catch (const std::exception& e) {
    return finish(RegistrationStatus::kInvalidInput, e.what());
  }
  result.counters.dropped_non_finite = sane.dropped_non_finite;
  const CorrespondenceSet& c = sane.correspondences;
  if (c.size() < 3)
    return finish(RegistrationStatus::kTooFewCorrespondences,
                  "need at least 3 finite correspondences, got " + std::to_string(c.size()));

  // Correspondence k becomes point k of both clouds. The rejector keys its model by source index, so
  // two matches sharing a source keypoint (common with nearest-neighbour matching) would collide if the
  // keypoint clouds were passed with keypoint indices.
  auto source = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  auto target = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl::Correspondences pairs;
  for (Eigen::Index k = 0; k < Eigen::Index(c.size()); ++k) {
    const Eigen::Vector3f s = c.source_points.col(k).cast<float>(), t = c.target_points.col(k).cast<float>();
    source->push_back(pcl::PointXYZ(s.x(), s.y(), s.z()));
    target->push_back(pcl::PointXYZ(t.x(), t.y(), t.z()));
    pairs.emplace_back(int(k), int(k), 0.0f);
  }
  pcl::registration::CorrespondenceRejectorSampleConsensus<pcl::PointXYZ> rejector;
  rejector.setInputSource(source);
  rejector.setInputTarget(target);
  rejector.setInlierThreshold(params.inlier_threshold);
  rejector.setMaximumIterations(params.max_iterations);
  rejector.setRefineModel(params.refine);
  rejector.setSaveInliers(true);
  pcl::Correspondences kept;
  rejector.getRemainingCorrespondences(pairs, kept);
  std::vector<int> inliers;
  rejector.getInliersIndices(inliers);
  // The rejector answers "no model" by returning every correspondence with an identity transform.
  if (inliers.empty())
    return finish(RegistrationStatus::kNoValidHypothesis, "RANSAC found no model with 3 or more inliers");

  Eigen::Matrix4d T = rejector.getBestTransformation().cast<double>();
  result.T_target_source.matrix() = T;
  // Re-orthonormalize: the float model of PCL is not exactly a rotation.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(T.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1.0;
    R = U * svd.matrixV().transpose();
  }
  result.T_target_source.linear() = R;
  // Inliers at the given threshold, as MAC counts them: PCL's refinement narrows its own threshold to
  // three standard deviations of the residuals, so its inlier set is not comparable.
  for (Eigen::Index k = 0; k < Eigen::Index(c.size()); ++k) {
    if ((result.T_target_source * c.source_points.col(k) - c.target_points.col(k)).norm() <
        params.inlier_threshold)
      result.inlier_indices.push_back(sane.original_index[k]);
  }
  result.counters.inliers = result.inlier_indices.size();
  result.score = double(result.counters.inliers);
  if (result.counters.inliers < params.min_inliers)
    return finish(RegistrationStatus::kTooFewInliers,
                  "RANSAC model has " + std::to_string(result.counters.inliers) + " inliers, fewer than " +
                      std::to_string(params.min_inliers));
  return finish(RegistrationStatus::kSuccess, "RANSAC: " + std::to_string(result.counters.inliers) +
                                                  " inliers of " + std::to_string(c.size()));
}

}  // namespace mac_registration
