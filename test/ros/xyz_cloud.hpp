#pragma once

// A well-formed float32 x y z PointCloud2 of given points: the starting point of the ROS tests' clouds.

#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace mac_registration::test {

inline sensor_msgs::PointCloud2 xyzCloud(const std::vector<Eigen::Vector3f>& points,
                                         const std::string& frame = "") {
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(points.size());
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z");
  for (const auto& p : points) {
    *x = p.x(), *y = p.y(), *z = p.z();
    ++x, ++y, ++z;
  }
  return msg;
}

}  // namespace mac_registration::test
