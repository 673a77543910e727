#include "mac_registration/features/query_window.hpp"

#include <cmath>
#include <stdexcept>

#include "mac_registration/features/cloud_filtering.hpp"
#include "mac_registration/features/voxel_downsampling.hpp"

namespace mac_registration {

namespace {

constexpr double kKeyframesPerWindow = 16.0;
const double kKeyframeTurn = 10.0 * M_PI / 180.0;  // [rad]

}  // namespace

QueryWindow::QueryWindow(const QueryWindowParams& params) : params_(params) {
  if (!(params.length >= 0.0)) throw std::invalid_argument("query window: length must be >= 0 [m]");
  if (!(params.max_age >= 0.0)) throw std::invalid_argument("query window: max_age must be >= 0 [s]");
  if (!(params.voxel_size > 0.0)) throw std::invalid_argument("query window: voxel_size must be > 0 [m]");
}

bool QueryWindow::wantsScan(const Eigen::Isometry3d& T_odom_scan) const {
  if (keyframes_.empty()) return true;
  const Eigen::Isometry3d motion = newestPose().inverse() * T_odom_scan;
  return motion.translation().norm() >= params_.length / kKeyframesPerWindow ||
         Eigen::AngleAxisd(motion.linear()).angle() >= kKeyframeTurn;
}

void QueryWindow::add(const PointCloud& scan, const Eigen::Isometry3d& T_odom_scan, double stamp) {
  if (!keyframes_.empty() && stamp < latest_stamp_) clear();
  latest_stamp_ = stamp;
  if (!wantsScan(T_odom_scan)) {
    dropExpired();
    return;
  }
  std::size_t dropped = 0;
  const PointCloud::Ptr finite = finitePoints(scan, dropped);
  Keyframe keyframe{finite->empty() ? finite : voxelDownsample(*finite, params_.voxel_size), T_odom_scan,
                    stamp, 0.0};
  if (!keyframes_.empty()) {
    keyframe.travel =
        keyframes_.back().travel + (T_odom_scan.translation() - newestPose().translation()).norm();
  }
  keyframes_.push_back(std::move(keyframe));
  dropExpired();
}

void QueryWindow::dropExpired() {
  const Keyframe& newest = keyframes_.back();
  while (keyframes_.size() > 1 && (newest.travel - keyframes_.front().travel > params_.length ||
                                   latest_stamp_ - keyframes_.front().stamp > params_.max_age)) {
    keyframes_.pop_front();
  }
}

void QueryWindow::clear() { keyframes_.clear(); }

double QueryWindow::travel() const {
  return keyframes_.empty() ? 0.0 : keyframes_.back().travel - keyframes_.front().travel;
}

PointCloud::Ptr QueryWindow::assemble() const {
  auto cloud = pcl::make_shared<PointCloud>();
  if (keyframes_.empty()) return cloud;
  const Eigen::Isometry3d T_newest_odom = newestPose().inverse();
  for (const Keyframe& keyframe : keyframes_) {
    const Eigen::Affine3f T = (T_newest_odom * keyframe.T_odom_scan).cast<float>();
    for (const pcl::PointXYZ& p : *keyframe.points) {
      const Eigen::Vector3f q = T * p.getVector3fMap();
      cloud->push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
    }
  }
  return cloud;
}

}  // namespace mac_registration
