#include "mac_registration/ros/conversions.hpp"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace mac_registration {
namespace {

// Checks that x, y, z are float32 fields inside each point and the data is as long as declared; fills
// their byte offsets.
std::string checkXyzLayout(const sensor_msgs::PointCloud2& msg, std::uint32_t (&offsets)[3]) {
  int axis = 0;
  for (const char* name : {"x", "y", "z"}) {
    const sensor_msgs::PointField* field = nullptr;
    for (const auto& f : msg.fields) {
      if (f.name == name) field = &f;
    }
    if (!field) return std::string("no '") + name + "' field (fields must include float32 x, y, z)";
    if (field->datatype != sensor_msgs::PointField::FLOAT32) {
      return std::string("field '") + name + "' is not float32 (datatype " + std::to_string(field->datatype) +
             ")";
    }
    if (field->offset + 4 > msg.point_step)
      return std::string("field '") + name + "' lies outside point_step";
    offsets[axis++] = field->offset;
  }
  if (std::size_t(msg.point_step) * msg.width > msg.row_step)
    return "row_step is smaller than point_step x width";
  if (std::size_t(msg.row_step) * msg.height > msg.data.size()) {
    return "data holds " + std::to_string(msg.data.size()) +
           " bytes, fewer than row_step x height = " + std::to_string(std::size_t(msg.row_step) * msg.height);
  }
  return "";
}

}  // namespace

CloudConversion toPointCloud(const sensor_msgs::PointCloud2& msg) {
  CloudConversion out;
  if (std::size_t(msg.width) * msg.height == 0) {
    out.error = "empty cloud (width x height = 0)";
    return out;
  }
  std::uint32_t offsets[3];
  out.error = checkXyzLayout(msg, offsets);
  if (!out.error.empty()) return out;
  out.cloud.reset(new PointCloud);
  out.cloud->reserve(std::size_t(msg.width) * msg.height);
  // Rows advance by row_step, so organized clouds and padded layouts are read correctly.
  for (std::uint32_t row = 0; row < msg.height; ++row) {
    const std::uint8_t* base = msg.data.data() + std::size_t(row) * msg.row_step;
    for (std::uint32_t col = 0; col < msg.width; ++col) {
      const std::uint8_t* point = base + std::size_t(col) * msg.point_step;
      float xyz[3];
      for (int a = 0; a < 3; ++a) std::memcpy(&xyz[a], point + offsets[a], sizeof(float));
      if (std::isfinite(xyz[0]) && std::isfinite(xyz[1]) && std::isfinite(xyz[2])) {
        out.cloud->push_back(pcl::PointXYZ(xyz[0], xyz[1], xyz[2]));
      } else {
        ++out.dropped_non_finite;
      }
    }
  }
  out.cloud->width = static_cast<std::uint32_t>(out.cloud->size());
  out.cloud->height = 1;
  out.cloud->is_dense = true;
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

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& T) {
  geometry_msgs::Transform msg;
  msg.translation.x = T.translation().x();
  msg.translation.y = T.translation().y();
  msg.translation.z = T.translation().z();
  const Eigen::Quaterniond q(T.linear());
  msg.rotation.x = q.x(), msg.rotation.y = q.y(), msg.rotation.z = q.z(), msg.rotation.w = q.w();
  return msg;
}

void fillResultMsg(const MacResult& r, mac_registration::RegistrationResult& msg) {
  msg.success = r.success;
  msg.status = toString(r.status);
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
  msg.time_graph_ms = r.times.graph_ms;
  msg.time_second_order_ms = r.times.second_order_ms;
  msg.time_clique_search_ms = r.times.clique_search_ms;
  msg.time_selection_ms = r.times.selection_ms;
  msg.time_hypotheses_ms = r.times.hypotheses_ms;
  msg.time_evaluation_ms = r.times.evaluation_ms;
  msg.time_refinement_ms = r.times.refinement_ms;
  msg.time_total_ms = r.times.total_ms + msg.time_front_end_ms;
}

void fillFrontEndStats(const FrontEndStats& s, mac_registration::RegistrationResult& msg) {
  msg.source_points = s.source_points;
  msg.target_points = s.target_points;
  msg.dropped_points = s.source_dropped + s.target_dropped;
  msg.source_keypoints = s.source_keypoints;
  msg.target_keypoints = s.target_keypoints;
  msg.resolution = s.resolution;
  msg.time_front_end_ms = s.totalMs();
}

}  // namespace mac_registration
