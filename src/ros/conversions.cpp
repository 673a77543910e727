#include "mac_registration/ros/conversions.hpp"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "mac_registration/features/cloud_filtering.hpp"

namespace mac_registration {
namespace {

// Where x, y and z lie in each point, and whether their bytes must be swapped to host order.
struct XyzLayout {
  std::uint32_t offsets[3] = {0, 0, 0};
  bool swap_bytes = false;
};

bool hostIsBigEndian() {
  const std::uint16_t probe = 1;
  std::uint8_t first_byte;
  std::memcpy(&first_byte, &probe, 1);
  return first_byte == 0;
}

// The single float32 field `name` within point_step, or why there is none. All arithmetic on the
// message's numbers is done in 64 bits: an offset near 2^32 must not wrap around the check.
std::string findFloatField(const sensor_msgs::PointCloud2& msg, const std::string& name,
                           std::uint32_t& offset) {
  const sensor_msgs::PointField* field = nullptr;
  int matches = 0;
  for (const auto& f : msg.fields) {
    if (f.name == name) field = &f, ++matches;
  }
  if (matches == 0) return "no '" + name + "' field (fields must include float32 x, y, z)";
  if (matches > 1) return std::to_string(matches) + " fields named '" + name + "' (which one is meant?)";
  if (field->datatype != sensor_msgs::PointField::FLOAT32) {
    return "field '" + name + "' is not float32 (datatype " + std::to_string(field->datatype) + ")";
  }
  if (std::uint64_t(field->offset) + sizeof(float) > msg.point_step) {
    return "field '" + name + "' at offset " + std::to_string(field->offset) + " lies outside point_step " +
           std::to_string(msg.point_step);
  }
  offset = field->offset;
  return "";
}

// Checks that x, y, z are distinct float32 fields inside each point, each row holds its points and the
// data is as long as declared; fills their byte offsets.
std::string checkXyzLayout(const sensor_msgs::PointCloud2& msg, XyzLayout& layout) {
  if (msg.point_step == 0) return "point_step is 0";
  const char* names[3] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    const std::string problem = findFloatField(msg, names[axis], layout.offsets[axis]);
    if (!problem.empty()) return problem;
    for (int other = 0; other < axis; ++other) {
      const std::uint32_t a = layout.offsets[other], b = layout.offsets[axis];
      if ((a > b ? a - b : b - a) < sizeof(float))
        return std::string("fields '") + names[other] + "' and '" + names[axis] + "' overlap";
    }
  }
  const std::uint64_t row_bytes = std::uint64_t(msg.point_step) * msg.width;
  if (row_bytes > msg.row_step) {
    return "row_step " + std::to_string(msg.row_step) +
           " is smaller than point_step x width = " + std::to_string(row_bytes);
  }
  const std::uint64_t data_bytes = std::uint64_t(msg.row_step) * msg.height;
  if (data_bytes > msg.data.size()) {
    return "data holds " + std::to_string(msg.data.size()) +
           " bytes, fewer than row_step x height = " + std::to_string(data_bytes);
  }
  layout.swap_bytes = bool(msg.is_bigendian) != hostIsBigEndian();
  return "";
}

float readFloat(const std::uint8_t* bytes, bool swap_bytes) {
  std::uint32_t word;
  std::memcpy(&word, bytes, sizeof word);
  if (swap_bytes) word = __builtin_bswap32(word);
  float value;
  std::memcpy(&value, &word, sizeof value);
  return value;
}

}  // namespace

CloudConversion toPointCloud(const sensor_msgs::PointCloud2& msg) {
  CloudConversion out;
  if (std::uint64_t(msg.width) * msg.height == 0) {
    out.error = "empty cloud (width x height = 0)";
    return out;
  }
  XyzLayout layout;
  out.error = checkXyzLayout(msg, layout);
  if (!out.error.empty()) return out;
  auto cloud = pcl::make_shared<PointCloud>();
  // Bounded by the data: every point takes at least 4 of its bytes (checked above).
  cloud->reserve(std::size_t(msg.width) * msg.height);
  // Rows advance by row_step, so organized clouds and padded layouts are read correctly.
  for (std::uint32_t row = 0; row < msg.height; ++row) {
    const std::uint8_t* base = msg.data.data() + std::size_t(row) * msg.row_step;
    for (std::uint32_t col = 0; col < msg.width; ++col) {
      const std::uint8_t* point = base + std::size_t(col) * msg.point_step;
      const pcl::PointXYZ p(readFloat(point + layout.offsets[0], layout.swap_bytes),
                            readFloat(point + layout.offsets[1], layout.swap_bytes),
                            readFloat(point + layout.offsets[2], layout.swap_bytes));
      if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) {
        ++out.dropped_non_finite;
        continue;
      }
      // Refused here, before the front end builds any kd-tree or voxel grid on it.
      out.error = coordinateBoundProblem(p, std::size_t(row) * msg.width + col);
      if (!out.error.empty()) return out;
      cloud->push_back(p);
    }
  }
  if (cloud->size() < 3 && out.dropped_non_finite > 0) {
    // Said here, where the cloud's own size is still known: the front end sees only the finite points.
    out.error = std::to_string(cloud->size()) + " of its " +
                std::to_string(std::uint64_t(msg.width) * msg.height) +
                " points are finite (the others hold NaN or Inf); at least 3 are needed";
    return out;
  }
  cloud->width = static_cast<std::uint32_t>(cloud->size());
  cloud->height = 1;
  cloud->is_dense = true;
  out.cloud = cloud;
  return out;
}

sensor_msgs::PointCloud2 toPointCloud2(const PointCloud& cloud, const Eigen::Isometry3d& T,
                                       const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 msg;
  msg.header = header;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(cloud.size());
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z");
  const Eigen::Isometry3f Tf = T.cast<float>();
  for (const auto& p : cloud) {
    const Eigen::Vector3f q = Tf * p.getVector3fMap();
    *x = q.x(), *y = q.y(), *z = q.z();
    ++x, ++y, ++z;
  }
  return msg;
}

CorrespondenceSet toCorrespondences(const mac_registration::Correspondences& msg) {
  if (msg.source_points.size() != msg.target_points.size()) {
    throw std::invalid_argument("source_points has " + std::to_string(msg.source_points.size()) +
                                " entries but target_points has " + std::to_string(msg.target_points.size()));
  }
  CorrespondenceSet c;
  const auto n = static_cast<Eigen::Index>(msg.source_points.size());
  c.source_points.resize(3, n);
  c.target_points.resize(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& s = msg.source_points[i];
    const auto& t = msg.target_points[i];
    c.source_points.col(i) << s.x, s.y, s.z;
    c.target_points.col(i) << t.x, t.y, t.z;
  }
  return c;
}

mac_registration::Correspondences toCorrespondencesMsg(const CorrespondenceSet& c,
                                                       const std_msgs::Header& header,
                                                       const std::string& source_frame) {
  mac_registration::Correspondences msg;
  msg.header = header;
  msg.source_frame = source_frame;
  msg.source_points.resize(c.size());
  msg.target_points.resize(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    auto& s = msg.source_points[i];
    auto& t = msg.target_points[i];
    s.x = c.source_points(0, i), s.y = c.source_points(1, i), s.z = c.source_points(2, i);
    t.x = c.target_points(0, i), t.y = c.target_points(1, i), t.z = c.target_points(2, i);
  }
  return msg;
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& msg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(msg.rotation.w, msg.rotation.x, msg.rotation.y, msg.rotation.z)
                   .normalized()
                   .toRotationMatrix();
  T.translation() << msg.translation.x, msg.translation.y, msg.translation.z;
  return T;
}

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T) {
  const geometry_msgs::Transform t = toTransformMsg(T);
  geometry_msgs::Pose pose;
  pose.position.x = t.translation.x, pose.position.y = t.translation.y, pose.position.z = t.translation.z;
  pose.orientation = t.rotation;
  return pose;
}

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& T) {
  geometry_msgs::Transform msg;
  msg.translation.x = T.translation().x();
  msg.translation.y = T.translation().y();
  msg.translation.z = T.translation().z();
  const Eigen::Quaterniond q(T.linear());
  msg.rotation.x = q.x(), msg.rotation.y = q.y(), msg.rotation.z = q.z(), msg.rotation.w = q.w();
  return msg;
}

namespace {

using ResultMsg = mac_registration::RegistrationResult;

// Every enum value needs its case (-Wswitch, an error in CI), and each case is checked below to be the
// same number as the message's constant: the enum and the message cannot drift apart unnoticed.
constexpr std::uint8_t statusConstant(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kSuccess:
      return ResultMsg::SUCCESS;
    case RegistrationStatus::kInvalidParameters:
      return ResultMsg::INVALID_PARAMETERS;
    case RegistrationStatus::kInvalidInput:
      return ResultMsg::INVALID_INPUT;
    case RegistrationStatus::kTooFewCorrespondences:
      return ResultMsg::TOO_FEW_CORRESPONDENCES;
    case RegistrationStatus::kEmptyGraph:
      return ResultMsg::EMPTY_GRAPH;
    case RegistrationStatus::kNoClique:
      return ResultMsg::NO_CLIQUE;
    case RegistrationStatus::kNoValidHypothesis:
      return ResultMsg::NO_VALID_HYPOTHESIS;
    case RegistrationStatus::kTooFewInliers:
      return ResultMsg::TOO_FEW_INLIERS;
    case RegistrationStatus::kInternalError:
      return ResultMsg::INTERNAL_ERROR;
    case RegistrationStatus::kCancelled:
      return ResultMsg::CANCELLED;
    case RegistrationStatus::kUnverified:
      return ResultMsg::UNVERIFIED;
  }
  return ResultMsg::INTERNAL_ERROR;
}

constexpr bool mirrors(RegistrationStatus status) {
  return statusConstant(status) == static_cast<std::uint8_t>(status);
}
static_assert(mirrors(RegistrationStatus::kSuccess) && mirrors(RegistrationStatus::kInvalidParameters) &&
                  mirrors(RegistrationStatus::kInvalidInput) &&
                  mirrors(RegistrationStatus::kTooFewCorrespondences) &&
                  mirrors(RegistrationStatus::kEmptyGraph) && mirrors(RegistrationStatus::kNoClique) &&
                  mirrors(RegistrationStatus::kNoValidHypothesis) &&
                  mirrors(RegistrationStatus::kTooFewInliers) &&
                  mirrors(RegistrationStatus::kInternalError) && mirrors(RegistrationStatus::kCancelled) &&
                  mirrors(RegistrationStatus::kUnverified),
              "RegistrationResult.msg's status constants must equal mac_registration::RegistrationStatus");

}  // namespace

std::uint8_t toStatusMsg(RegistrationStatus status) { return statusConstant(status); }

std::string statusName(std::uint8_t status) {
  if (status == ResultMsg::MISSING_ODOMETRY) return "missing odometry";
  if (status <= static_cast<std::uint8_t>(RegistrationStatus::kUnverified))
    return toString(static_cast<RegistrationStatus>(status));
  return "unknown status " + std::to_string(status);
}

void fillResultMsg(const MacResult& r, mac_registration::RegistrationResult& msg) {
  msg.success = r.success;
  msg.status = toStatusMsg(r.status);
  msg.message = r.message;
  msg.warnings.insert(msg.warnings.end(), r.warnings.begin(), r.warnings.end());
  msg.transform = toTransformMsg(r.success ? r.T_target_source : Eigen::Isometry3d::Identity());
  msg.score = r.score;
  msg.correspondences = r.counters.correspondences;
  msg.graph_edges = r.counters.graph_edges;
  msg.cliques = r.counters.cliques;
  msg.selected_cliques = r.counters.selected_cliques;
  msg.hypotheses = r.counters.hypotheses;
  msg.inliers = r.counters.inliers;
  msg.clique_search_complete = r.clique_search_complete;
  fillStageTimes(r.times, msg);
  fillVerification(r, msg);
}

void fillStageTimes(const StageTimes& t, mac_registration::RegistrationResult& msg) {
  msg.time_front_end_ms = t.frontEndMs();
  msg.time_graph_ms = t.graph_ms;
  msg.time_second_order_ms = t.second_order_ms;
  msg.time_clique_search_ms = t.clique_search_ms;
  msg.time_selection_ms = t.selection_ms;
  msg.time_hypotheses_ms = t.hypotheses_ms;
  msg.time_evaluation_ms = t.evaluation_ms;
  msg.time_refinement_ms = t.refinement_ms;
  msg.time_verification_ms = t.verification_ms;
  msg.time_fine_alignment_ms = t.fine_alignment_ms;
  msg.time_total_ms = t.total_ms;
}

void fillVerification(const MacResult& r, mac_registration::RegistrationResult& msg) {
  msg.confidence = r.confidence;
  msg.has_estimate = hasEstimate(r);
  msg.estimate = toTransformMsg(msg.has_estimate ? r.T_target_source : Eigen::Isometry3d::Identity());
  const VerificationSignals& s = r.verification;
  msg.rival_ratio = s.rival_ratio;
  msg.rival_rotation_deg = s.rival_rotation_deg;
  msg.rival_displacement = s.rival_displacement;
  msg.aligned_overlap = s.aligned_overlap;
  msg.seen_on_surface = s.seen_on_surface;
  msg.free_space_violation = s.free_space_violation;
  msg.surface_agreement = s.surface_agreement;
  msg.chance_inliers = s.chance_inliers;
  msg.chance_significance = s.chance_significance;
  msg.inlier_planarity = s.inlier_planarity;
  msg.inlier_linearity = s.inlier_linearity;
  msg.scene_planarity = s.scene_planarity;
  msg.fine_alignment_ran = r.fine_alignment.ran;
  msg.fine_alignment_move = s.fine_alignment_move;
  msg.fine_alignment_converged = s.fine_alignment_converged == 1.0;
  msg.fine_alignment_support = s.fine_alignment_support;
  msg.fine_alignment_fitness = r.fine_alignment.ran ? r.fine_alignment.fitness : kNotMeasured;
  msg.fine_alignment_rmse = r.fine_alignment.ran ? r.fine_alignment.rmse : kNotMeasured;
  for (int k = 0; k < 36; ++k)
    msg.covariance[std::size_t(k)] =
        r.fine_alignment.ran ? r.fine_alignment.covariance(k / 6, k % 6) : kNotMeasured;
  msg.alternatives.clear();
  for (const PoseAlternative& a : r.alternatives) {
    mac_registration::CompetingPose alternative;
    alternative.transform = toTransformMsg(a.T_target_source);
    alternative.score = a.score;
    alternative.inliers = a.inliers;
    alternative.score_ratio = a.score_ratio;
    alternative.rotation_deg = a.rotation_deg;
    alternative.displacement = a.displacement;
    msg.alternatives.push_back(alternative);
  }
}

void fillFrontEndStats(const FrontEndStats& s, mac_registration::RegistrationResult& msg) {
  msg.source_points = s.source_points;
  msg.target_points = s.target_points;
  msg.dropped_points = s.source_dropped + s.target_dropped;
  msg.source_keypoints = s.source_keypoints;
  msg.target_keypoints = s.target_keypoints;
  msg.resolution = s.resolution;
}

}  // namespace mac_registration
