#include "mac_registration/ros/visualization.hpp"

#include <geometry_msgs/Point.h>

#include <utility>

namespace mac_registration {
namespace {

geometry_msgs::Point toPoint(const Eigen::Vector3d& v) {
  geometry_msgs::Point p;
  p.x = v.x(), p.y = v.y(), p.z = v.z();
  return p;
}

visualization_msgs::Marker lineList(const std_msgs::Header& header, const char* ns, double width, float r,
                                    float g, float b) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = 0;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.color.r = r, m.color.g = g, m.color.b = b, m.color.a = 0.8f;
  return m;
}

}  // namespace

visualization_msgs::MarkerArray correspondenceMarkers(const CorrespondenceSet& c,
                                                      const std::vector<int>& inliers,
                                                      const Eigen::Isometry3d& T,
                                                      const std_msgs::Header& header, double line_width,
                                                      int max_outlier_lines) {
  std::vector<char> is_inlier(c.size(), 0);
  for (int i : inliers) is_inlier[i] = 1;
  visualization_msgs::Marker inlier_lines = lineList(header, "inliers", line_width, 0.1f, 0.9f, 0.2f);
  // As wide as the inliers: thinner red lines vanish at the distances a whole scan is looked at from.
  visualization_msgs::Marker outlier_lines = lineList(header, "outliers", line_width, 0.9f, 0.2f, 0.1f);
  const std::size_t outliers = c.size() - inliers.size();
  const std::size_t stride =
      max_outlier_lines > 0 ? std::max<std::size_t>(1, outliers / std::size_t(max_outlier_lines) + 1) : 0;
  std::size_t outlier_rank = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const bool inlier = is_inlier[i];
    if (!inlier && (stride == 0 || outlier_rank++ % stride != 0)) continue;
    auto& marker = inlier ? inlier_lines : outlier_lines;
    marker.points.push_back(toPoint(T * c.source_points.col(i)));
    marker.points.push_back(toPoint(c.target_points.col(i)));
  }
  visualization_msgs::MarkerArray array;
  // An empty LINE_LIST is refused by rviz; DELETE clears the previous lines instead.
  for (auto* m : {&inlier_lines, &outlier_lines}) {
    if (m->points.empty()) m->action = visualization_msgs::Marker::DELETE;
    array.markers.push_back(std::move(*m));
  }
  return array;
}

}  // namespace mac_registration
