// The readers of mac_benchmark's datasets on hand-made files: 3DMatch gt.log, the pairs table,
// correspondence sets.
#include <gtest/gtest.h>

#include "benchmark_datasets.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

using test::TempDir;

// Two records in the 3DMatch layout (tabs and scientific notation as shipped): 0 <- 1 a translation,
// 2 <- 5 a rotation of 90 deg about z.
const char* kGtLog =
    "0\t 1\t 60\t\n"
    " 1.0e+00\t 0.0e+00\t 0.0e+00\t 1.5e-01\t\n 0\t 1\t 0\t -2.0e-01\t\n 0\t 0\t 1\t 3e-01\n 0\t 0\t 0\t 1\n"
    "2\t 5\t 60\t\n"
    " 0 -1 0 0\n 1 0 0 0\n 0 0 1 0\n 0 0 0 1\n";

TEST(GtLog, SourceIsTheSecondIndexAndTMapsItIntoTheFirst) {
  TempDir dir;
  const auto records = readGtLog(dir.write("gt.log", kGtLog));
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].target_index, 0);
  EXPECT_EQ(records[0].source_index, 1);
  EXPECT_DOUBLE_EQ(records[0].T_target_source.translation().y(), -0.2);
  // p_2 = T p_5: the x axis of fragment 5 is the y axis of fragment 2.
  EXPECT_TRUE(records[1].T_target_source.linear().col(0).isApprox(Eigen::Vector3d::UnitY()));
}

TEST(GtLog, TruncatedRecordsAreRefusedWithTheirLine) {
  TempDir dir;
  try {
    readGtLog(dir.write("gt.log", "0 1 60\n1 0 0 0\n0 1 0 0\n"));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("gt.log:3:"), std::string::npos) << e.what();
  }
}

TEST(GtLog, PairsOnlyForFragmentsThatExist) {
  TempDir dir;
  const std::string scene = dir.file("kitchen");
  std::filesystem::create_directories(scene);
  for (const char* name : {"cloud_bin_0.ply", "cloud_bin_1.pcd", "cloud_bin_2.ply"})
    dir.write("kitchen/" + std::string(name), "");
  std::vector<std::string> missing;
  const auto pairs = pairsFromGtLog(scene, dir.write("gt.log", kGtLog), "3DMatch", missing);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].name, "kitchen 1->0");
  EXPECT_EQ(pairs[0].subset, "3DMatch");
  EXPECT_EQ(pairs[0].scene, "kitchen");
  EXPECT_EQ(pairs[0].source_path, scene + "/cloud_bin_1.pcd");
  EXPECT_EQ(pairs[0].target_path, scene + "/cloud_bin_0.ply");
  EXPECT_EQ(missing, std::vector<std::string>{"5->2"});
}

TEST(PairsTable, ReadsTheShippedLayoutWithPathsRelativeToTheTable) {
  TempDir dir;
  const std::string table = dir.write(
      "pairs.tsv",
      "# comment\n"
      "scene\ti_target\tj_source\tbenchmark\tpredator_overlap\ttarget_file\tsource_file\tT(row-major 4x4)\n"
      "kitchen\t0\t7\t3DLoMatch\t0.28\tfrag/cloud_bin_0.ply\tfrag/cloud_bin_7.pcd\t"
      "1 0 0 0.5 0 1 0 0 0 0 1 0 0 0 0 1\n");
  const auto pairs = readPairsTable(table);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].name, "kitchen 7->0");
  EXPECT_EQ(pairs[0].subset, "3DLoMatch");
  EXPECT_EQ(pairs[0].scene, "kitchen");
  EXPECT_EQ(pairs[0].source_path, dir.file("frag/cloud_bin_7.pcd"));
  EXPECT_DOUBLE_EQ(pairs[0].T_target_source_gt.translation().x(), 0.5);
  EXPECT_TRUE(pairs[0].hasClouds());
}

TEST(PairsTable, PairsWithoutARightAnswerAndNamedRows) {
  TempDir dir;
  const std::string table = dir.write("negatives.tsv",
                                      "scene\tbenchmark\tname\ttarget_file\tsource_file\tT\n"
                                      "kitchen\tno overlap\t1->21 (0 %)\ta.ply\tb.ply\tnone\n"
                                      "kitchen\tright\t\ta.ply\tb.ply\t1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n");
  const auto pairs = readPairsTable(table);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_FALSE(pairs[0].has_ground_truth);
  EXPECT_EQ(pairs[0].name, "kitchen 1->21 (0 %)");
  EXPECT_EQ(pairs[0].subset, "no overlap");
  EXPECT_TRUE(pairs[1].has_ground_truth);
  EXPECT_EQ(pairs[1].name, "kitchen row 3");  // no name, no indices: the line
}

TEST(PairsTable, MissingColumnsAndShortMatricesAreRefused) {
  TempDir dir;
  EXPECT_THROW(readPairsTable(dir.write("a.tsv", "source_file\ttarget_file\n")), std::runtime_error);
  EXPECT_THROW(readPairsTable(dir.write("b.tsv", "source_file\ttarget_file\tT\ns.pcd\tt.pcd\t1 0 0\n")),
               std::runtime_error);
  EXPECT_THROW(readPairsTable(dir.file("missing.tsv")), std::runtime_error);
}

TEST(CorrespondenceSets, FromAFolderInTheMacAuthorsLayout) {
  TempDir dir;
  std::filesystem::create_directories(dir.file("KITTI"));
  dir.write("KITTI/b@corr.txt", "");
  dir.write("KITTI/b@GTmat.txt", "1 0 0 2\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  dir.write("KITTI/a@corr.txt", "");
  dir.write("KITTI/a@GTmat.txt", "1 0 0 1\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  dir.write("KITTI/a@label.txt", "");
  const auto sets = readCorrespondenceSets(dir.file("KITTI"));
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[0].name, "a");  // sorted, whatever the directory order
  EXPECT_EQ(sets[0].subset, "KITTI");
  EXPECT_DOUBLE_EQ(sets[1].T_target_source_gt.translation().x(), 2.0);
  EXPECT_FALSE(sets[0].hasClouds());

  dir.write("KITTI/c@corr.txt", "");  // no ground truth
  EXPECT_THROW(readCorrespondenceSets(dir.file("KITTI")), std::runtime_error);
}

TEST(CorrespondenceSets, FromAListFile) {
  TempDir dir;
  dir.write("gt.txt", "1 0 0 0\n0 1 0 0\n0 0 1 3\n");
  const auto sets =
      readCorrespondenceSets(dir.write("list.txt", "# corr gt subset\nx.txt gt.txt hard\ny.txt gt.txt\n"));
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[0].subset, "hard");
  EXPECT_EQ(sets[1].subset, "all");
  EXPECT_EQ(sets[0].correspondences_path, dir.file("x.txt"));
  EXPECT_DOUBLE_EQ(sets[1].T_target_source_gt.translation().z(), 3.0);
  EXPECT_TRUE(sets[0].has_ground_truth);
  const auto negatives = readCorrespondenceSets(dir.write("negatives.txt", "z.txt none unrelated\n"));
  ASSERT_EQ(negatives.size(), 1u);
  EXPECT_FALSE(negatives[0].has_ground_truth);
  EXPECT_EQ(negatives[0].subset, "unrelated");
}

}  // namespace
}  // namespace mac_registration
