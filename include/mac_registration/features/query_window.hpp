#pragma once

// A relocalization query put together from the scans of the last metres of travel. A single lidar scan is
// too sparse to be described like an accumulated map (on the NCLT campus 8 % of single scans are found in
// the map, 90 % of 16 m windows); the odometry, which drifts little over such a distance, joins the scans
// into one local cloud that is.

#include <Eigen/Geometry>
#include <cstddef>
#include <deque>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {

struct QueryWindowParams {
  double length = 16.0;     // [m] of travel the window spans (0: the latest scan alone)
  double max_age = 60.0;    // [s] keyframes older than this, counted from the latest scan, leave the window
  double voxel_size = 0.2;  // [m] each kept scan is downsampled to it (the map's voxel size)
};

// Keeps a scan as a keyframe when the sensor has moved length / 16 or turned 10 degrees since the last
// one, so that a robot standing still holds one keyframe, not a minute of identical scans; the window's
// memory is bounded by 16 downsampled scans (plus those of a length travelled in turns).
class QueryWindow {
 public:
  // Throws std::invalid_argument for a negative length or age or a voxel size that is not positive.
  explicit QueryWindow(const QueryWindowParams& params);

  // Whether a scan at `T_odom_scan` would be kept: the caller converts only the scans that will be.
  bool wantsScan(const Eigen::Isometry3d& T_odom_scan) const;
  // Adds `scan` (its own frame; non-finite points are dropped) taken at `stamp` [s] with the sensor at
  // `T_odom_scan`, when wantsScan(), and drops the keyframes that fall out of the window (the newest
  // stays, however old). Every scan's stamp counts for the age, kept or not. A stamp older than the
  // latest one clears the window first (a replayed bag, a reset clock).
  void add(const PointCloud& scan, const Eigen::Isometry3d& T_odom_scan, double stamp);
  void clear();

  bool empty() const { return keyframes_.empty(); }
  std::size_t keyframes() const { return keyframes_.size(); }
  // [m] of travel between the oldest and the newest keyframe.
  double travel() const;
  // The keyframes in the newest keyframe's frame (its sensor at the origin); empty when the window is.
  PointCloud::Ptr assemble() const;
  // The newest keyframe: the frame assemble() returns, its odometry pose and stamp [s].
  const Eigen::Isometry3d& newestPose() const { return keyframes_.back().T_odom_scan; }
  double newestStamp() const { return keyframes_.back().stamp; }

 private:
  struct Keyframe {
    PointCloud::Ptr points;
    Eigen::Isometry3d T_odom_scan;
    double stamp;
    double travel;  // [m] along the path from the first keyframe ever added
  };
  void dropExpired();

  QueryWindowParams params_;
  std::deque<Keyframe> keyframes_;
  double latest_stamp_ = 0.0;  // [s] of the latest scan added, kept or not
};

}  // namespace mac_registration
