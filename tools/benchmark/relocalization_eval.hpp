#pragma once

// The relocalization benchmark: queries with their true pose in a map, localized one after the other in the
// map described once (mac_benchmark relocalize).

#include <Eigen/Geometry>
#include <ostream>
#include <string>
#include <vector>

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {

struct RelocalizationQuery {
  std::string name, path;
  Eigen::Isometry3d T_map_query = Eigen::Isometry3d::Identity();  // the truth
};

// A table of "name <TAB> query file <TAB> T_map_query (16 numbers, row-major)" lines after a header line;
// relative query paths are taken from the table's folder.
std::vector<RelocalizationQuery> readRelocalizationTable(const std::string& path);

struct RelocalizationSettings {
  RegistrationConfig config;
  double max_rotation_deg = 5.0, max_translation = 1.0;  // the success criterion [deg], [m]
  // > 0: the map is cropped to the square of this half-width [m] around the mean of the queries' true
  // positions (the map-size sweep).
  double crop_half_width = 0.0;
  // > 0: the peer beside ours, in the same run: PCL's SampleConsensusPrerejective (the engine of
  // hdl_global_localization's FPFH + RANSAC) of the query's keypoints and FPFH against the whole map's, the
  // same descriptors ours uses, with this many iterations.
  int peer_iterations = 0;
};

// Describes the map, localizes every query, prints a line per query and the summary to `out`, and per-query
// rows to `csv` when it is open. Returns 0.
int runRelocalizationBenchmark(const std::string& map_path, const std::vector<RelocalizationQuery>& queries,
                               const RelocalizationSettings& settings, std::ostream& out, std::ostream* csv);

}  // namespace mac_registration
