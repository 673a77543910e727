#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <mac_registration/Correspondences.h>
#include <mac_registration/RegistrationResult.h>
#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <string>

#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {

// A PointCloud2 checked and reduced to its finite x y z points.
struct CloudConversion {
  PointCloud::Ptr cloud;  // null when error is set
  std::size_t dropped_non_finite = 0;
  std::string error;  // why the message cannot be used, empty if it can
};

// Accepts any layout with float32 x, y, z fields (organized or not, any other fields, either byte order:
// is_bigendian is honoured); refuses with a reason empty clouds, missing, duplicated, overlapping or
// non-float32 x/y/z, fields outside point_step (point_step 0 included), rows longer than row_step, data
// shorter than its declared size, and finite coordinates beyond kMaxAbsCoordinate. The reason does not
// name the cloud: callers prefix its role ("source cloud: ...").
CloudConversion toPointCloud(const sensor_msgs::PointCloud2& msg);

// An x y z float32 PointCloud2 of `cloud`, transformed by T.
sensor_msgs::PointCloud2 toPointCloud2(const PointCloud& cloud, const Eigen::Isometry3d& T,
                                       const std_msgs::Header& header);

// Throws std::invalid_argument when the point arrays differ in length.
CorrespondenceSet toCorrespondences(const mac_registration::Correspondences& msg);

// The message form of a correspondence set (header.frame_id = target frame).
mac_registration::Correspondences toCorrespondencesMsg(const CorrespondenceSet& correspondences,
                                                       const std_msgs::Header& target_header,
                                                       const std::string& source_frame);

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& T);
// The same as a pose (position and orientation).
geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T);
Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& msg);

// RegistrationResult.status of a core outcome: the same number (the message's constants mirror the enum).
std::uint8_t toStatusMsg(RegistrationStatus status);

// The words of a RegistrationResult.status, for logs ("too few inliers", "missing odometry").
std::string statusName(std::uint8_t status);

// Fills the core part of a result message (status, transform, counters, the core's times).
void fillResultMsg(const MacResult& result, mac_registration::RegistrationResult& msg);
// The message's time_*_ms fields, each from the StageTimes field of its name (time_front_end_ms: the front
// end's stages together). From clouds: CloudRegistrationResult::times(), after fillResultMsg.
void fillStageTimes(const StageTimes& times, mac_registration::RegistrationResult& msg);
// The verification's part of the message (fillResultMsg calls it): confidence, the estimate (also when
// unverified), the signals and the alternatives.
void fillVerification(const MacResult& result, mac_registration::RegistrationResult& msg);
// The front end's counters (its times go with the core's, through fillStageTimes).
void fillFrontEndStats(const FrontEndStats& stats, mac_registration::RegistrationResult& msg);

}  // namespace mac_registration
