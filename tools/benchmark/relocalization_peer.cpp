#include "relocalization_peer.hpp"

#include <pcl/registration/sample_consensus_prerejective.h>

#include <chrono>

namespace mac_registration {

namespace {

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

struct RansacPeer::Search {
  pcl::SampleConsensusPrerejective<pcl::PointXYZ, pcl::PointXYZ, pcl::FPFHSignature33> ransac;
};

RansacPeer::RansacPeer(const DescribedMap& map, int iterations, double tau)
    : map_(map), search_(std::make_unique<Search>()) {
  const auto start = std::chrono::steady_clock::now();
  auto& r = search_->ransac;
  r.setInputTarget(map.cloud.keypoints);
  r.setTargetFeatures(map.cloud.descriptors);
  r.setMaximumIterations(iterations);
  r.setNumberOfSamples(3);
  r.setCorrespondenceRandomness(2);
  r.setSimilarityThreshold(0.5f);
  r.setMaxCorrespondenceDistance(tau);
  r.setInlierFraction(0.25f);
  setup_ms = millisecondsSince(start);
}

RansacPeer::~RansacPeer() = default;

RansacPeer::Answer RansacPeer::localize(const PointCloud& query, const FeatureParams& features) {
  const auto start = std::chrono::steady_clock::now();
  Answer answer;
  const DescribedCloud described = describeCloud(query, features, "query");
  auto& r = search_->ransac;
  r.setInputSource(described.keypoints);
  r.setSourceFeatures(described.descriptors);
  PointCloud aligned;
  r.align(aligned);
  answer.converged = r.hasConverged();
  answer.T_map_query.matrix() = r.getFinalTransformation().cast<double>();
  answer.T_map_query = Eigen::Translation3d(map_.origin) * answer.T_map_query;
  answer.ms = millisecondsSince(start);
  return answer;
}

}  // namespace mac_registration
