#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mac_registration {

// The clouds of the front end: points (metres), their normals, their FPFH descriptors.
using PointCloud = pcl::PointCloud<pcl::PointXYZ>;
using NormalCloud = pcl::PointCloud<pcl::Normal>;
using FpfhCloud = pcl::PointCloud<pcl::FPFHSignature33>;

}  // namespace mac_registration
