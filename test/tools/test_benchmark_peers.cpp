// mac_benchmark's per-stage shares, its Open3D peers and its 3DMatch layout, run as a user runs them: the
// shares of a real run account for its total, the Open3D script's report is parsed into the outcome of a
// real pair, and the threedmatch mode finds the scenes it can run and names those it cannot.
// The Open3D cases skip, saying so, only when the script cannot import open3d (python3-open3d).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "benchmark_table.hpp"
#include "cli_run.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "open3d_peer.hpp"
#include "synthetic.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

using test::CliRun;
using test::runTool;
using test::TempDir;

CliRun runBenchmark(const std::string& arguments) { return runTool(MAC_BENCHMARK_BIN, arguments); }

std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  for (char c : line) {
    if (c == '"')
      quoted = !quoted;
    else if (c == ',' && !quoted) {
      fields.push_back(field);
      field.clear();
    } else
      field += c;
  }
  fields.push_back(field);
  return fields;
}

// The rows of a CSV as column name -> field.
std::vector<std::map<std::string, std::string>> readCsv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::map<std::string, std::string>> rows;
  if (!std::getline(in, line)) return rows;
  const std::vector<std::string> header = splitCsvLine(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = splitCsvLine(line);
    std::map<std::string, std::string> row;
    for (std::size_t k = 0; k < header.size() && k < fields.size(); ++k) row[header[k]] = fields[k];
    rows.push_back(row);
  }
  return rows;
}

double number(const std::map<std::string, std::string>& row, const std::string& column) {
  const auto it = row.find(column);
  if (it == row.end() || it->second.empty()) return std::nan("");
  return std::stod(it->second);
}

// The share columns of a row: "other" apart from the timed stages.
struct Shares {
  double timed = 0.0, other = 0.0;
  int columns = 0;
};

Shares sharesOf(const std::map<std::string, std::string>& row) {
  Shares s;
  const std::string suffix = "_share_pct";
  for (const auto& [column, value] : row) {
    if (column.size() <= suffix.size() ||
        column.compare(column.size() - suffix.size(), suffix.size(), suffix))
      continue;
    ++s.columns;
    (column == "other" + suffix ? s.other : s.timed) += std::stod(value);
  }
  return s;
}

std::string dataPath(const std::string& name) { return std::string(MAC_TEST_DATA_DIR) + "/" + name; }
std::string demoDataPath(const std::string& name) { return std::string(MAC_DATA_DIR) + "/" + name; }

// The shipped pair (redkitchen 4 -> 0, 13.6 k points each) as a one-row pairs table.
std::string tinyPairsTable(const TempDir& dir) {
  std::ifstream gt(demoDataPath("redkitchen_4_0/T_target_source_gt.txt"));
  std::string T, word;
  while (gt >> word) T += word + " ";
  return dir.write("pairs.tsv", "name\tbenchmark\tsource_file\ttarget_file\tT\n4->0\ttiny\t" +
                                    demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd") + "\t" +
                                    demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd") + "\t" + T + "\n");
}

// The shipped pair in the 3DMatch layout: fragments/kitchen/cloud_bin_{0,4}.pcd; 3DMatch and 3DLoMatch
// gt.logs of kitchen (3DLoMatch also lists 9 -> 0, whose fragment is absent), and of hotel, which has no
// fragments. Returns the two roots.
std::pair<std::string, std::string> tinyThreeDMatch(const TempDir& dir) {
  namespace fs = std::filesystem;
  fs::create_directories(dir.file("fragments/kitchen"));
  fs::copy_file(demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd"),
                dir.file("fragments/kitchen/cloud_bin_4.pcd"));
  fs::copy_file(demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd"),
                dir.file("fragments/kitchen/cloud_bin_0.pcd"));
  std::ifstream gt(demoDataPath("redkitchen_4_0/T_target_source_gt.txt"));
  const std::string record = "0 4 60\n" + std::string(std::istreambuf_iterator<char>(gt), {});
  const std::string identity = "0 9 60\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  for (const char* folder :
       {"benchmarks/3DMatch/kitchen", "benchmarks/3DMatch/hotel", "benchmarks/3DLoMatch/kitchen"})
    fs::create_directories(dir.file(folder));
  dir.write("benchmarks/3DMatch/kitchen/gt.log", record);
  dir.write("benchmarks/3DMatch/hotel/gt.log", record);
  dir.write("benchmarks/3DLoMatch/kitchen/gt.log", record + identity);
  return {dir.file("fragments"), dir.file("benchmarks")};
}

// Empty when the script can run Open3D, else why not.
std::string open3dMissing() {
  try {
    requireOpen3d(Open3dSettings{});
    return "";
  } catch (const std::exception& e) {
    return e.what();
  }
}

#define SKIP_WITHOUT_OPEN3D()                                                                    \
  do {                                                                                           \
    const std::string why = open3dMissing();                                                     \
    if (!why.empty()) {                                                                          \
      if (why.find("python3-open3d") == std::string::npos) FAIL() << why;                        \
      GTEST_SKIP() << "open3d cannot be imported (install python3-open3d to run this): " << why; \
    }                                                                                            \
  } while (0)

TEST(StageShares, OtherHoldsTheUntimedRestAndSharesAddUpToTheTotal) {
  StageTimes f;
  f.features_ms = 30.0;
  StageTimes s;
  s.graph_ms = 10.0;
  s.clique_search_ms = 40.0;
  double sum = 0.0;
  for (const StageShare& stage : stageShares(f, s, 100.0)) {
    sum += stage.percent;
    if (std::string(stage.name) == "other") {
      EXPECT_DOUBLE_EQ(stage.ms, 20.0);
    }
    if (std::string(stage.name) == "cliques") {
      EXPECT_DOUBLE_EQ(stage.percent, 40.0);
    }
  }
  EXPECT_DOUBLE_EQ(sum, 100.0);
  // Stages longer than the total (medians of stages against the median of totals): no negative rest.
  EXPECT_DOUBLE_EQ(stageShares(f, s, 50.0).back().ms, 0.0);
}

TEST(MacBenchmarkShares, CorrespondencesRunsStagesCoverTheTotal) {
  TempDir dir;
  const CliRun r = runBenchmark("correspondences " + dataPath("redkitchen_24_59/correspondences.txt") + " " +
                                dataPath("redkitchen_24_59/T_target_source_gt.txt") +
                                " --repeats 1 --set num_threads=1 --csv " + dir.file("out.csv"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("share of the median total per stage"), std::string::npos) << r.output;
  const auto rows = readCsv(dir.file("out.csv"));
  ASSERT_EQ(rows.size(), 1u);
  const Shares s = sharesOf(rows[0]);
  EXPECT_EQ(s.columns, 9);  // graph .. verify, other
  // One repeat: its stages' times against its own total. The timed stages are nearly all of it.
  EXPECT_NEAR(s.timed + s.other, 100.0, 0.01);
  EXPECT_GT(s.timed, 75.0) << "stages account for " << s.timed << " % of the total";
}

TEST(MacBenchmarkShares, PairsRunsSharesOfFrontEndAndCoreAddUp) {
  TempDir dir;
  const CliRun r =
      runBenchmark("pairs " + tinyPairsTable(dir) + " --config " + std::string(MAC_CONFIG_DIR) +
                   "/indoor_rgbd.yaml --baseline none --set num_threads=1 --csv " + dir.file("out.csv"));
  ASSERT_EQ(r.status, 0) << r.output;
  const auto rows = readCsv(dir.file("out.csv"));
  ASSERT_EQ(rows.size(), 1u);
  const auto& mac = rows[0];
  EXPECT_EQ(mac.at("method"), "MAC");
  const Shares s = sharesOf(mac);
  EXPECT_EQ(s.columns, 14);  // 5 front-end stages, 8 core stages, other
  EXPECT_NEAR(s.timed + s.other, 100.0, 0.01);
  EXPECT_GT(s.timed, 75.0) << "stages account for " << s.timed << " % of the total";
  EXPECT_GT(number(mac, "fpfh_share_pct"), 0.0);
  EXPECT_GT(number(mac, "cliques_share_pct"), 0.0);
  // The total the shares are of: front end and method.
  const double front = number(mac, "resolution_ms") + number(mac, "downsample_ms") +
                       number(mac, "normals_ms") + number(mac, "fpfh_ms") + number(mac, "matching_ms");
  EXPECT_NEAR(number(mac, "total_ms"), front + number(mac, "method_total_ms"), 1e-3);
  EXPECT_GT(number(mac, "peak_mb"), 1.0);
  EXPECT_EQ(number(mac, "source_points"), 13622.0);
}

TEST(Open3dPeer, ReportsMissingOpen3dByItsPackage) {
  TempDir dir;
  Open3dSettings settings;
  // A stand-in script that fails as open3d_baseline.py does when `import open3d` fails.
  settings.script = dir.write("no_open3d.py", "import sys\nsys.stderr.write('no open3d\\n')\nsys.exit(3)\n");
  try {
    requireOpen3d(settings);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("python3-open3d"), std::string::npos) << e.what();
  }
  settings.python = dir.file("no_such_python");
  EXPECT_THROW(requireOpen3d(settings), std::runtime_error);
}

TEST(Open3dPeer, ParserNamesTheMissingKey) {
  try {
    parseOpen3dClouds("open3d_version 0.16.1\nsource_points 10\n");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("target_points"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parseOpen3dFgr("open3d_version 0.16.1\nfile a\ncorrespondences 3\nfgr_ms 1\nT 1 0 0\n"),
               std::runtime_error);
}

TEST(Open3dPeer, CloudsReportIsParsedAndAlignsTheShippedPair) {
  SKIP_WITHOUT_OPEN3D();
  const Open3dCloudsRun run =
      runOpen3dClouds(Open3dSettings{}, demoDataPath("redkitchen_4_0/source_cloud_bin_4.pcd"),
                      demoDataPath("redkitchen_4_0/target_cloud_bin_0.pcd"), 0.05, 1);
  EXPECT_EQ(run.version.rfind("0.", 0), 0u) << run.version;
  EXPECT_EQ(run.source_points, 13622u);
  EXPECT_EQ(run.target_points, 13555u);
  EXPECT_GT(run.source_keypoints, 1000u);
  EXPECT_LT(run.source_keypoints, run.source_points);
  EXPECT_GT(run.fpfh_ms, 0.0);
  EXPECT_GT(run.registration_ms, 0.0);
  EXPECT_NEAR(run.total_ms, run.downsample_ms + run.normals_ms + run.fpfh_ms + run.registration_ms, 1e-2);
  EXPECT_GT(run.peak_mb, 10.0);
  EXPECT_GT(run.inliers, 100u);
  const Eigen::Isometry3d gt = readTransformFile(demoDataPath("redkitchen_4_0/T_target_source_gt.txt"));
  EXPECT_LT(rotationErrorDeg(run.T_target_source, gt), 15.0);
  EXPECT_LT(translationError(run.T_target_source, gt), 0.3);
}

TEST(Open3dPeer, FgrReportIsParsedAndRecoversACleanSet) {
  SKIP_WITHOUT_OPEN3D();
  SyntheticSpec spec;
  spec.correspondences = 300;
  spec.inlier_ratio = 0.8;
  spec.noise_sigma = 0.002;
  spec.object_size = 1.0;
  spec.seed = 3;
  const SyntheticProblem problem =
      makeSyntheticProblem(readAsciiPlyMesh(dataPath("teaser_bun_zipper_res3.ply")), spec);
  TempDir dir;
  std::ostringstream text;
  text.precision(9);
  for (Eigen::Index c = 0; c < problem.correspondences.source_points.cols(); ++c)
    text << problem.correspondences.source_points.col(c).transpose() << " "
         << problem.correspondences.target_points.col(c).transpose() << "\n";
  const std::string file = dir.write("set.txt", text.str());
  const Open3dFgrRuns runs = runOpen3dFgr(Open3dSettings{}, {file, file}, 0.02);
  ASSERT_EQ(runs.runs.size(), 2u);
  EXPECT_EQ(runs.runs[0].file, file);
  EXPECT_EQ(runs.runs[0].correspondences, 300u);
  EXPECT_GT(runs.runs[1].fgr_ms, 0.0);
  EXPECT_GT(runs.peak_mb, 10.0);
  EXPECT_LT(rotationErrorDeg(runs.runs[0].T_target_source, problem.T_target_source), 2.0);
  EXPECT_LT(translationError(runs.runs[0].T_target_source, problem.T_target_source), 0.02);
}

TEST(MacBenchmarkPeers, PairsWithOpen3dReportBothSideBySide) {
  SKIP_WITHOUT_OPEN3D();
  TempDir dir;
  const CliRun r =
      runBenchmark("pairs " + tinyPairsTable(dir) + " --config " + std::string(MAC_CONFIG_DIR) +
                   "/indoor_rgbd.yaml --baseline open3d --set num_threads=1 --csv " + dir.file("out.csv"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("MAC beside Open3D pair by pair"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("median ratio MAC/Open3D over 1 pairs"), std::string::npos) << r.output;
  const auto rows = readCsv(dir.file("out.csv"));
  ASSERT_EQ(rows.size(), 2u);  // MAC and Open3D: no RANSAC when not asked for
  EXPECT_EQ(rows[0].at("method"), "MAC");
  const auto& open3d = rows[1];
  EXPECT_EQ(open3d.at("method"), "Open3D");
  EXPECT_EQ(open3d.at("recalled"), "1") << open3d.at("status");
  EXPECT_GT(number(open3d, "fpfh_ms"), 0.0);
  EXPECT_EQ(number(open3d, "matching_ms"), 0.0);  // inside its registration
  EXPECT_GT(number(open3d, "peak_mb"), 10.0);
  EXPECT_NEAR(sharesOf(open3d).timed + sharesOf(open3d).other, 100.0, 0.01);
}

TEST(MacBenchmarkPeers, CorrespondencesWithFgrReportItsTime) {
  SKIP_WITHOUT_OPEN3D();
  TempDir dir;
  const CliRun r = runBenchmark("correspondences " + dataPath("redkitchen_24_59/correspondences.txt") + " " +
                                dataPath("redkitchen_24_59/T_target_source_gt.txt") +
                                " --repeats 1 --baseline fgr --csv " + dir.file("out.csv"));
  ASSERT_EQ(r.status, 0) << r.output;
  const auto rows = readCsv(dir.file("out.csv"));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_GT(number(rows[0], "fgr_ms"), 0.0);
  EXPECT_FALSE(std::isnan(number(rows[0], "fgr_median_re_deg")));
  EXPECT_GE(number(rows[0], "fgr_recalled"), 0.0);  // of one repeat
  EXPECT_LE(number(rows[0], "fgr_recalled"), 1.0);
}

TEST(MacBenchmarkThreeDMatch, RunsEveryScenePairWithFragmentsAndNamesWhatItSkips) {
  TempDir dir;
  const auto [fragments, benchmarks] = tinyThreeDMatch(dir);
  const CliRun r = runBenchmark(
      "threedmatch " + fragments + " " + benchmarks + " --config " + std::string(MAC_CONFIG_DIR) +
      "/indoor_rgbd.yaml --baseline none --set num_threads=1 --csv " + dir.file("out.csv"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("3DMatch: 1 of 2 scenes with a gt.log; skipped, no fragments in " + fragments +
                          ": hotel"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("3DLoMatch kitchen: skipped 1 of 2 pairs, a fragment missing (first 9->0)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("| 3DMatch | all 1 scene | 1 | 100.00 % (1) |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| 3DLoMatch | kitchen | 1 | 100.00 % (1) |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| 3DLoMatch | **0.5** | 1 | 1 | 100.00 % | 0 (0) | 0.00 % |"), std::string::npos)
      << r.output;
  const auto rows = readCsv(dir.file("out.csv"));
  ASSERT_EQ(rows.size(), 2u);  // one CSV for both benchmarks
  EXPECT_EQ(rows[0].at("subset"), "3DMatch");
  EXPECT_EQ(rows[1].at("subset"), "3DLoMatch");
  EXPECT_EQ(rows[1].at("scene"), "kitchen");
  EXPECT_EQ(rows[1].at("within_criterion"), "1");
  EXPECT_GE(number(rows[1], "confidence"), 0.5);

  const CliRun unknown =
      runBenchmark("threedmatch " + fragments + " " + benchmarks + " --scenes kitchen,kitchn");
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.output.find("'kitchn'"), std::string::npos) << unknown.output;
}

}  // namespace
}  // namespace mac_registration
