#include "benchmark_datasets.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "mac_registration/core/text_io.hpp"

namespace mac_registration {
namespace {

namespace fs = std::filesystem;

std::ifstream openOrThrow(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "' for reading");
  return in;
}

std::string where(const std::string& path, int line) { return path + ":" + std::to_string(line) + ": "; }

std::string relativeTo(const std::string& base_file, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute()) return path;
  return (fs::path(base_file).parent_path() / path).lexically_normal().string();
}

std::vector<std::string> splitTabs(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  for (std::string field; std::getline(in, field, '\t');) {
    if (!field.empty() && field.back() == '\r') field.pop_back();
    fields.push_back(field);
  }
  return fields;
}

Eigen::Isometry3d parseRowMajor(const std::string& text, const std::string& context) {
  std::istringstream in(text);
  double v[16];
  for (double& x : v) {
    if (!(in >> x)) throw std::runtime_error(context + "expected 16 numbers (row-major 4x4)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = v[4 * r + c];
  return T;
}

std::string fragmentPath(const std::string& folder, int index) {
  for (const char* extension : {".ply", ".pcd"}) {
    const fs::path path = fs::path(folder) / ("cloud_bin_" + std::to_string(index) + extension);
    if (fs::exists(path)) return path.string();
  }
  return "";
}

}  // namespace

std::vector<GtLogRecord> readGtLog(const std::string& path) {
  std::ifstream in = openOrThrow(path);
  std::vector<GtLogRecord> records;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    GtLogRecord record;
    std::istringstream header(line);
    if (!(header >> record.target_index >> record.source_index))
      throw std::runtime_error(where(path, number) + "expected a record header 'i j N'");
    std::string rows;
    for (int r = 0; r < 4; ++r) {
      if (!std::getline(in, line))
        throw std::runtime_error(where(path, number) + "record ends before its 4x4 matrix");
      ++number;
      rows += line + " ";
    }
    record.T_target_source = parseRowMajor(rows, where(path, number));
    records.push_back(record);
  }
  return records;
}

std::vector<BenchmarkPair> pairsFromGtLog(const std::string& fragment_dir, const std::string& gt_log,
                                          const std::string& subset, std::vector<std::string>& missing) {
  const std::string scene = fs::path(fragment_dir).lexically_normal().filename().string();
  std::vector<BenchmarkPair> pairs;
  for (const GtLogRecord& record : readGtLog(gt_log)) {
    const std::string label =
        std::to_string(record.source_index) + "->" + std::to_string(record.target_index);
    BenchmarkPair pair;
    pair.source_path = fragmentPath(fragment_dir, record.source_index);
    pair.target_path = fragmentPath(fragment_dir, record.target_index);
    if (pair.source_path.empty() || pair.target_path.empty()) {
      missing.push_back(label);
      continue;
    }
    pair.name = scene + " " + label;
    pair.subset = subset;
    pair.scene = scene;
    pair.T_target_source_gt = record.T_target_source;
    pairs.push_back(pair);
  }
  return pairs;
}

std::vector<BenchmarkPair> readPairsTable(const std::string& path) {
  std::ifstream in = openOrThrow(path);
  std::map<std::string, std::size_t> column;
  std::vector<BenchmarkPair> pairs;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> fields = splitTabs(line);
    if (column.empty()) {
      for (std::size_t c = 0; c < fields.size(); ++c)
        column[!fields[c].empty() && fields[c][0] == 'T' ? "T" : fields[c]] = c;
      for (const char* required : {"source_file", "target_file", "T"}) {
        if (!column.count(required))
          throw std::runtime_error(where(path, number) + "the header has no '" + required + "' column");
      }
      continue;
    }
    const auto field = [&](const std::string& name) -> std::string {
      const auto it = column.find(name);
      if (it == column.end()) return "";
      if (it->second >= fields.size())
        throw std::runtime_error(where(path, number) + "missing the '" + name + "' field");
      return fields[it->second];
    };
    BenchmarkPair pair;
    pair.source_path = relativeTo(path, field("source_file"));
    pair.target_path = relativeTo(path, field("target_file"));
    if (field("T") == "none")
      pair.has_ground_truth = false;
    else
      pair.T_target_source_gt = parseRowMajor(field("T"), where(path, number));
    pair.subset = field("benchmark").empty() ? "all" : field("benchmark");
    const std::string i = field("i_target"), j = field("j_source");
    const std::string label = !field("name").empty()   ? field("name")
                              : i.empty() || j.empty() ? "row " + std::to_string(number)
                                                       : j + "->" + i;
    pair.scene = field("scene");
    pair.name = (pair.scene.empty() ? "" : pair.scene + " ") + label;
    pairs.push_back(pair);
  }
  if (column.empty()) throw std::runtime_error("'" + path + "' has no header row");
  return pairs;
}

std::vector<BenchmarkPair> readCorrespondenceSets(const std::string& folder_or_list) {
  std::vector<BenchmarkPair> sets;
  if (fs::is_directory(folder_or_list)) {
    const std::string subset = fs::path(folder_or_list).lexically_normal().filename().string();
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder_or_list)) files.push_back(entry.path());
    std::sort(files.begin(), files.end());  // directory order is the file system's: make it stable
    const std::string suffix = "@corr.txt";
    for (const fs::path& file : files) {
      const std::string name = file.filename().string();
      if (name.size() <= suffix.size() ||
          name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
        continue;
      const std::string stem = name.substr(0, name.size() - suffix.size());
      const fs::path gt = file.parent_path() / (stem + "@GTmat.txt");
      if (!fs::exists(gt))
        throw std::runtime_error("'" + file.string() + "' has no ground truth '" + gt.string() + "'");
      BenchmarkPair set;
      set.name = stem;
      set.subset = subset;
      set.correspondences_path = file.string();
      set.T_target_source_gt = readTransformFile(gt.string());
      sets.push_back(set);
    }
  } else {
    std::ifstream in = openOrThrow(folder_or_list);
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      std::istringstream fields(line);
      std::string corr, gt, subset;
      if (!(fields >> corr) || corr[0] == '#') continue;
      if (!(fields >> gt))
        throw std::runtime_error(where(folder_or_list, number) + "expected 'CORR_FILE GT_FILE [SUBSET]'");
      fields >> subset;
      BenchmarkPair set;
      set.name = fs::path(corr).stem().string();
      set.subset = subset.empty() ? "all" : subset;
      set.correspondences_path = relativeTo(folder_or_list, corr);
      if (gt == "none")
        set.has_ground_truth = false;
      else
        set.T_target_source_gt = readTransformFile(relativeTo(folder_or_list, gt));
      sets.push_back(set);
    }
  }
  if (sets.empty()) throw std::runtime_error("no correspondence sets in '" + folder_or_list + "'");
  return sets;
}

}  // namespace mac_registration
