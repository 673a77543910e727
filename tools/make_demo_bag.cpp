// make_demo_bag OUT.bag DATA_DIR: writes the demo's rosbag from the shipped scan pairs, so that the bag is
// made from files in the repository, not committed as a blob. Each pair is published every few seconds with
// source and target at the same stamp (the demo node pairs them by stamp), with its ground truth on a
// geometry_msgs/TransformStamped topic; and once a cycle a relocalization query with its pose in the map.
#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <rosbag/bag.h>

#include <iostream>
#include <string>

#include "mac_registration/core/text_io.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/ros/conversions.hpp"

namespace {

struct DemoPair {
  const char* name;  // topic namespace
  const char* source_file;
  const char* target_file;
  const char* truth_file;
  const char* source_frame;
  const char* target_frame;
};

constexpr DemoPair kPairs[] = {
    {"indoor", "data/redkitchen_4_0/source_cloud_bin_4.pcd", "data/redkitchen_4_0/target_cloud_bin_0.pcd",
     "data/redkitchen_4_0/T_target_source_gt.txt", "fragment_4", "fragment_0"},
    {"outdoor", "data/lidar/lidar_source_251371071.pcd", "data/lidar/lidar_target_251370668.pcd",
     "data/lidar/lidar_T_target_source_reference.txt", "lidar_source", "lidar_target"},
};
// The relocalization step: a local cloud of a campus drive (16 keyframes joined by odometry, in the newest
// one's frame) to be found in the campus map that relocalization_node loads, with its pose in the map.
constexpr const char* kQueryFile = "data/nclt_campus/query_window.pcd";
constexpr const char* kQueryTruthFile = "data/nclt_campus/T_map_query.txt";
constexpr const char* kQueryFrame = "campus_query";
constexpr const char* kMapFrame = "campus_map";
constexpr int kCycles = 3;
constexpr double kPeriod = 4.0;  // [s] between two publications of the same pair

}  // namespace

int main(int argc, char** argv) {
  using namespace mac_registration;
  const char* usage = "usage: make_demo_bag OUT.bag DATA_DIR (the package's source folder)\n";
  if (argc == 2 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help")) {
    std::cout << usage;
    return 0;
  }
  if (argc != 3) {
    std::cerr << usage;
    return 2;
  }
  const std::string root = argv[2];
  ros::Time::init();
  try {
    rosbag::Bag bag(argv[1], rosbag::bagmode::Write);
    for (int cycle = 0; cycle < kCycles; ++cycle) {
      for (std::size_t p = 0; p < std::size(kPairs); ++p) {
        const DemoPair& pair = kPairs[p];
        const ros::Time stamp(1.0 + cycle * kPeriod + p * kPeriod / 2.0);
        std_msgs::Header source_header, target_header;
        source_header.stamp = target_header.stamp = stamp;
        source_header.frame_id = pair.source_frame;
        target_header.frame_id = pair.target_frame;
        const std::string ns = std::string("/") + pair.name;
        bag.write(ns + "/target", stamp,
                  toPointCloud2(*loadCloud(root + "/" + pair.target_file), Eigen::Isometry3d::Identity(),
                                target_header));
        bag.write(ns + "/source", stamp,
                  toPointCloud2(*loadCloud(root + "/" + pair.source_file), Eigen::Isometry3d::Identity(),
                                source_header));
        geometry_msgs::TransformStamped truth;
        truth.header = target_header;
        truth.child_frame_id = pair.source_frame;
        truth.transform = toTransformMsg(readTransformFile(root + "/" + pair.truth_file));
        bag.write(ns + "/ground_truth", stamp, truth);
      }
      const ros::Time stamp(1.0 + (cycle + 0.25) * kPeriod);
      std_msgs::Header query_header;
      query_header.stamp = stamp;
      query_header.frame_id = kQueryFrame;
      bag.write(
          "/relocalization/scan", stamp,
          toPointCloud2(*loadCloud(root + "/" + kQueryFile), Eigen::Isometry3d::Identity(), query_header));
      geometry_msgs::TransformStamped truth;
      truth.header = query_header;
      truth.header.frame_id = kMapFrame;
      truth.child_frame_id = kQueryFrame;
      truth.transform = toTransformMsg(readTransformFile(root + "/" + kQueryTruthFile));
      bag.write("/relocalization/ground_truth", stamp, truth);
    }
    bag.close();
  } catch (const std::exception& e) {
    std::cerr << "make_demo_bag: " << e.what() << "\n";
    return 1;
  }
  std::cout << "make_demo_bag: wrote " << argv[1] << " (" << kCycles << " cycles of " << std::size(kPairs)
            << " pairs and a relocalization query)\n";
  return 0;
}
