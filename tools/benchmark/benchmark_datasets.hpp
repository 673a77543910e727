#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace mac_registration {

// One registration problem of a benchmark with its ground truth: two clouds, or a correspondence set.
struct BenchmarkPair {
  std::string name;    // for tables and progress lines, e.g. "7-scenes-redkitchen 1->0"
  std::string subset;  // rows of the table are per subset, e.g. "3DMatch", "3DLoMatch"
  std::string scene;   // where the clouds were taken, e.g. "7-scenes-redkitchen"; may be empty
  std::string source_path, target_path;  // clouds (both set), or
  std::string correspondences_path;      // a correspondence file ("xs ys zs xt yt zt" a line)
  Eigen::Isometry3d T_target_source_gt = Eigen::Isometry3d::Identity();
  // False for a pair with no right answer (clouds that do not overlap, unrelated scenes): its ground-truth
  // field is "none" in the table, and any success on it is a false accept.
  bool has_ground_truth = true;

  bool hasClouds() const { return correspondences_path.empty(); }
};

// A 3DMatch gt.log record: "i j N" then a row-major 4x4 T with p_i = T p_j, i.e. source = fragment j,
// target = fragment i, T = T_target_source.
struct GtLogRecord {
  int target_index = 0, source_index = 0;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
};

// Throws std::runtime_error naming file and line on anything but whole 5-line records.
std::vector<GtLogRecord> readGtLog(const std::string& path);

// The pairs of a gt.log whose fragments cloud_bin_<k>.ply (or .pcd) are in `fragment_dir`; the others
// are appended to `missing` as "j->i". Names are "<scene> j->i" with the scene the folder's name.
std::vector<BenchmarkPair> pairsFromGtLog(const std::string& fragment_dir, const std::string& gt_log,
                                          const std::string& subset, std::vector<std::string>& missing);

// A tab-separated table with a header row ('#' lines skipped): columns source_file, target_file and
// a T column (header starting with "T": 16 numbers, row-major T_target_source) are required; benchmark
// (the subset), scene, name (else i_target and j_source) are used when present. Relative paths are relative
// to the table's folder. This reads the shipped 3dmatch/pairs_available.tsv. A T field "none" marks a pair
// without a right answer (has_ground_truth false).
std::vector<BenchmarkPair> readPairsTable(const std::string& path);

// Correspondence sets with ground truth: either a folder of "<name>@corr.txt" + "<name>@GTmat.txt"
// (the MAC authors' layout; subset = the folder's name), or a list file of "CORR_FILE GT_FILE [SUBSET]"
// lines (relative to the list's folder; subset "all" when not given; GT_FILE "none" for a set without a
// right answer).
std::vector<BenchmarkPair> readCorrespondenceSets(const std::string& folder_or_list);

}  // namespace mac_registration
