// The arithmetic of mac_benchmark's table on hand-made outcomes whose recall, means and medians are
// known: what a paper would print from the same per-pair numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "benchmark_table.hpp"

namespace mac_registration {
namespace {

MethodOutcome method(const std::string& name, bool registered, double re, double te, double total_ms) {
  MethodOutcome m;
  m.method = name;
  m.registered = registered;
  m.rotation_error_deg = re;
  m.translation_error = te;
  m.times.total_ms = total_ms;
  m.times.graph_ms = total_ms / 10.0;
  return judge(m, SuccessCriterion{});
}

PairOutcome pair(const std::string& subset, double inlier_ratio, MethodOutcome mac, MethodOutcome ransac) {
  PairOutcome p;
  p.name = subset + " pair";
  p.subset = subset;
  p.correspondences = 100;
  p.inlier_ratio = inlier_ratio;
  p.front_end.features_ms = 300.0;
  p.methods = {mac, ransac};
  return p;
}

// 3DMatch: 4 pairs. MAC recalls 3 (the fourth registered but 20 deg off), RANSAC 2 (one failed, one
// 31 cm off). 3DLoMatch: 2 pairs, plus one whose clouds could not be read.
std::vector<PairOutcome> handMadeTable() {
  const double nan = std::nan("");
  std::vector<PairOutcome> outcomes = {
      pair("3DMatch", 0.10, method("MAC", true, 1.0, 0.02, 100), method("RANSAC", true, 2.0, 0.04, 1000)),
      pair("3DMatch", 0.20, method("MAC", true, 2.0, 0.04, 200), method("RANSAC", false, nan, nan, 2000)),
      pair("3DMatch", 0.30, method("MAC", true, 3.0, 0.06, 300), method("RANSAC", true, 3.0, 0.31, 3000)),
      pair("3DMatch", 0.40, method("MAC", true, 20.0, 0.05, 400), method("RANSAC", true, 4.0, 0.08, 4000)),
      pair("3DLoMatch", 0.01, method("MAC", true, 15.0, 0.30, 50), method("RANSAC", true, 15.01, 0.1, 500)),
      pair("3DLoMatch", 0.03, method("MAC", false, 1.0, 0.01, 70), method("RANSAC", true, 1.0, 0.01, 700)),
  };
  PairOutcome unreadable;
  unreadable.name = "unreadable";
  unreadable.subset = "3DLoMatch";
  unreadable.error = "cannot read cloud";
  outcomes.push_back(unreadable);
  return outcomes;
}

const SummaryRow& row(const std::vector<SummaryRow>& rows, const std::string& subset, const std::string& m) {
  for (const SummaryRow& r : rows) {
    if (r.subset == subset && r.method == m) return r;
  }
  throw std::runtime_error("no row " + subset + "/" + m);
}

TEST(Judge, AcceptsTheCriterionBoundaryAndNeedsASuccessReport) {
  EXPECT_TRUE(method("MAC", true, 15.0, 0.30, 1).recalled);  // <=, as the papers count
  EXPECT_FALSE(method("MAC", true, 15.0001, 0.1, 1).recalled);
  EXPECT_FALSE(method("MAC", true, 1.0, 0.3001, 1).recalled);
  EXPECT_FALSE(method("MAC", false, 1.0, 0.01, 1).recalled);  // a failure it reported is a failure
  EXPECT_FALSE(method("MAC", true, std::nan(""), std::nan(""), 1).recalled);
  SuccessCriterion lidar{5.0, 0.6};
  MethodOutcome m = method("MAC", true, 4.0, 0.5, 1);
  EXPECT_TRUE(judge(m, lidar).recalled);
  m.rotation_error_deg = 6.0;
  EXPECT_FALSE(judge(m, lidar).recalled);
}

TEST(Summary, RecallMeansAndMediansPerSubsetAndMethod) {
  const std::vector<SummaryRow> rows = summarize(handMadeTable());
  ASSERT_EQ(rows.size(), 6u);  // 2 subsets + all, x 2 methods
  EXPECT_EQ(rows[0].subset, "3DMatch");
  EXPECT_EQ(rows[0].method, "MAC");
  EXPECT_EQ(rows[1].method, "RANSAC");
  EXPECT_EQ(rows[4].subset, "all");

  const SummaryRow& mac = row(rows, "3DMatch", "MAC");
  EXPECT_EQ(mac.pairs, 4u);
  EXPECT_EQ(mac.recalled, 3u);
  EXPECT_DOUBLE_EQ(mac.recall, 0.75);
  EXPECT_DOUBLE_EQ(mac.mean_rotation_error_deg, 2.0);  // (1 + 2 + 3) / 3: the 20 deg miss is not averaged
  EXPECT_DOUBLE_EQ(mac.mean_translation_error, 0.04);
  EXPECT_DOUBLE_EQ(mac.mean_inlier_ratio, 0.25);
  EXPECT_DOUBLE_EQ(mac.median_times.total_ms, 250.0);  // even count: mean of the middle two
  EXPECT_DOUBLE_EQ(mac.median_times.graph_ms, 25.0);
  EXPECT_DOUBLE_EQ(mac.median_front_end.features_ms, 300.0);

  const SummaryRow& ransac = row(rows, "3DMatch", "RANSAC");
  EXPECT_EQ(ransac.recalled, 2u);
  EXPECT_DOUBLE_EQ(ransac.mean_rotation_error_deg, 3.0);  // pairs 1 and 4
  EXPECT_DOUBLE_EQ(ransac.median_times.total_ms, 2500.0);
}

TEST(Summary, UnrunnablePairsCountAsMissesButNotInTheMeans) {
  const std::vector<SummaryRow> rows = summarize(handMadeTable());
  const SummaryRow& mac = row(rows, "3DLoMatch", "MAC");
  EXPECT_EQ(mac.pairs, 3u);
  EXPECT_EQ(mac.recalled, 1u);  // 15 deg / 30 cm exactly; the other reported failure
  EXPECT_DOUBLE_EQ(mac.recall, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(mac.mean_inlier_ratio, 0.02);  // over the two that ran
  EXPECT_DOUBLE_EQ(mac.median_times.total_ms, 60.0);
  const SummaryRow& ransac = row(rows, "3DLoMatch", "RANSAC");
  EXPECT_EQ(ransac.recalled, 1u);  // 15.01 deg is out
  EXPECT_TRUE(std::isnan(row(summarize({handMadeTable()[1]}), "3DMatch", "RANSAC").mean_rotation_error_deg));

  const SummaryRow& all = row(rows, "all", "MAC");
  EXPECT_EQ(all.pairs, 7u);
  EXPECT_EQ(all.recalled, 4u);
  EXPECT_DOUBLE_EQ(all.recall, 4.0 / 7.0);
}

TEST(Summary, PrintsAndWritesEveryRow) {
  const std::vector<PairOutcome> outcomes = handMadeTable();
  std::ostringstream table, csv;
  printSummary(table, summarize(outcomes), SuccessCriterion{});
  EXPECT_NE(table.str().find("75.00%"), std::string::npos) << table.str();
  EXPECT_NE(table.str().find("RE <= 15 deg and TE <= 30 cm"), std::string::npos);
  writeOutcomesCsv(csv, outcomes);
  std::size_t lines = 0;
  for (char c : csv.str()) lines += c == '\n';
  EXPECT_EQ(lines, 1u + 6u * 2u + 1u);  // header, 6 pairs x 2 methods, the unreadable pair
  EXPECT_NE(csv.str().find("\"cannot read cloud\""), std::string::npos);
}

}  // namespace
}  // namespace mac_registration
