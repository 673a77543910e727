// The arithmetic of mac_benchmark threedmatch's tables on hand-made outcomes whose recall, wrong successes
// and false-accept rates at each threshold are known: what the MAC paper's table and the verification's
// sweep print from the same per-pair numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "paper_table.hpp"

namespace mac_registration {
namespace {

const double kNan = std::nan("");

PairOutcome pair(const std::string& benchmark, const std::string& scene, const std::string& status,
                 double confidence, double re, double te, double method_ms) {
  MethodOutcome m;
  m.method = "MAC";
  m.status = status;
  m.registered = status == "success";
  m.confidence = confidence;
  m.rotation_error_deg = re;
  m.translation_error = te;
  m.times.total_ms = method_ms;
  PairOutcome p;
  p.name = scene + " pair";
  p.subset = benchmark;
  p.scene = scene;
  p.front_end.features_ms = 100.0;
  p.methods = {judge(m, SuccessCriterion{})};
  return p;
}

// 3DMatch, run at min_confidence 0.5: kitchen then hotel (not in alphabetical order), 10 pairs.
//  1 kitchen success 0.9, right            6 hotel unverified 0.2, 90 deg off (gross)
//  2 kitchen success 0.6, right            7 hotel no clique: no pose
//  3 kitchen success 0.55, 20 deg off      8 hotel too few inliers, a right pose: not judged
//  4 kitchen unverified 0.3, right         9 hotel clouds unreadable
//  5 hotel success 0.7, 170 deg off        10 kitchen success 0.5, 30 deg and 1 m: wrong, not gross
// 3DLoMatch: a right success and a right unverified pose.
std::vector<PairOutcome> handMadeRun() {
  std::vector<PairOutcome> outcomes = {
      pair("3DMatch", "kitchen", "success", 0.9, 1.0, 0.02, 10),
      pair("3DMatch", "kitchen", "success", 0.6, 2.0, 0.04, 20),
      pair("3DMatch", "kitchen", "success", 0.55, 20.0, 0.1, 30),
      pair("3DMatch", "kitchen", "unverified", 0.3, 3.0, 0.06, 40),
      pair("3DMatch", "hotel", "success", 0.7, 170.0, 2.0, 50),
      pair("3DMatch", "hotel", "unverified", 0.2, 90.0, 0.5, 60),
      pair("3DMatch", "hotel", "no clique", 0.0, kNan, kNan, 70),
      pair("3DMatch", "hotel", "too few inliers", 0.0, 1.0, 0.01, 80),
  };
  PairOutcome unreadable;
  unreadable.name = "hotel unreadable";
  unreadable.subset = "3DMatch";
  unreadable.scene = "hotel";
  unreadable.error = "cannot read cloud";
  outcomes.push_back(unreadable);
  outcomes.push_back(pair("3DMatch", "kitchen", "success", 0.5, 30.0, 1.0, 100));
  outcomes.push_back(pair("3DLoMatch", "kitchen", "success", 0.95, 5.0, 0.1, 10));
  outcomes.push_back(pair("3DLoMatch", "kitchen", "unverified", 0.45, 10.0, 0.25, 10));
  return outcomes;
}

TEST(GrossError, StrictlyBeyondThirtyDegreesOrOneMetre) {
  const GrossError gross;
  EXPECT_FALSE(gross.classifies(30.0, 1.0));
  EXPECT_TRUE(gross.classifies(30.01, 0.0));
  EXPECT_TRUE(gross.classifies(0.0, 1.001));
  EXPECT_FALSE(gross.classifies(20.0, 0.5));
}

TEST(AcceptedAt, OnlyJudgedPosesAndTheRunsOwnComparison) {
  const std::vector<PairOutcome> run = handMadeRun();
  // At the run's own threshold the re-judged successes are exactly the reported ones.
  for (const PairOutcome& p : run) {
    if (!p.methods.empty()) {
      EXPECT_EQ(acceptedAt(p.methods[0], 0.5), p.methods[0].registered) << p.name;
    }
  }
  EXPECT_TRUE(acceptedAt(run[3].methods[0], 0.3));  // unverified at 0.5, its confidence reaches 0.3
  EXPECT_FALSE(acceptedAt(run[3].methods[0], 0.31));
  EXPECT_FALSE(acceptedAt(run[6].methods[0], 0.0));  // no clique: nothing judged
  EXPECT_FALSE(acceptedAt(run[7].methods[0], 0.0));  // too few inliers: another failure, never counted
  MethodOutcome ransac = run[0].methods[0];
  ransac.confidence = kNan;  // a baseline has no confidence
  EXPECT_FALSE(acceptedAt(ransac, 0.0));
}

TEST(PaperRows, RecallWrongSuccessesAndMeansPerBenchmarkAndScene) {
  const std::vector<PaperRow> rows = paperRows(handMadeRun(), "MAC", GrossError{}, true);
  ASSERT_EQ(rows.size(), 5u);  // 3DMatch, kitchen, hotel, 3DLoMatch, kitchen
  EXPECT_EQ(rows[0].benchmark, "3DMatch");
  EXPECT_EQ(rows[0].scene, "");
  EXPECT_EQ(rows[1].scene, "kitchen");  // order of first appearance
  EXPECT_EQ(rows[2].scene, "hotel");
  EXPECT_EQ(rows[3].benchmark, "3DLoMatch");

  const PaperRow& all = rows[0];
  EXPECT_EQ(all.scenes, 2u);
  EXPECT_EQ(all.pairs, 10u);  // the unreadable pair is a miss, not left out
  EXPECT_EQ(all.successes, 5u);
  EXPECT_EQ(all.right, 2u);
  EXPECT_EQ(all.wrong, 3u);
  EXPECT_EQ(all.gross, 1u);            // 170 deg; 20 deg and the 30 deg / 1 m boundary are not gross
  EXPECT_EQ(all.right_estimates, 3u);  // 1, 2 and the unverified 4; not the too-few-inliers pose
  EXPECT_DOUBLE_EQ(all.recall(), 0.2);
  EXPECT_DOUBLE_EQ(all.recallWithoutVerification(), 0.3);
  EXPECT_DOUBLE_EQ(all.falseAcceptRate(), 0.6);
  EXPECT_DOUBLE_EQ(all.mean_rotation_error_deg, 1.5);  // the recalled pairs only
  EXPECT_DOUBLE_EQ(all.mean_translation_error, 0.03);
  // Front end 100 + method 10..80 and 100 ms over the 9 pairs that ran.
  EXPECT_NEAR(all.mean_ms, 1360.0 / 9.0, 1e-9);
  EXPECT_DOUBLE_EQ(all.median_ms, 150.0);
  EXPECT_DOUBLE_EQ(all.median_method_ms, 50.0);

  const PaperRow& kitchen = rows[1];
  EXPECT_EQ(kitchen.pairs, 5u);
  EXPECT_EQ(kitchen.successes, 4u);
  EXPECT_EQ(kitchen.wrong, 2u);
  EXPECT_EQ(kitchen.gross, 0u);
  const PaperRow& hotel = rows[2];
  EXPECT_EQ(hotel.pairs, 5u);
  EXPECT_EQ(hotel.right, 0u);
  EXPECT_EQ(hotel.wrong, 1u);
  EXPECT_EQ(hotel.gross, 1u);
  EXPECT_DOUBLE_EQ(hotel.falseAcceptRate(), 1.0);
  EXPECT_TRUE(std::isnan(hotel.mean_rotation_error_deg));
  EXPECT_DOUBLE_EQ(hotel.mean_ms, 165.0);  // 150..180: the unreadable pair has no time

  const PaperRow& lo = rows[3];
  EXPECT_EQ(lo.pairs, 2u);
  EXPECT_DOUBLE_EQ(lo.recall(), 0.5);
  EXPECT_DOUBLE_EQ(lo.recallWithoutVerification(), 1.0);
  EXPECT_DOUBLE_EQ(lo.falseAcceptRate(), 0.0);

  EXPECT_EQ(paperRows(handMadeRun(), "MAC", GrossError{}, false).size(), 2u);
  // A stricter gross bound: the 30 deg / 1 m success and the 20 deg one become gross too.
  EXPECT_EQ(paperRows(handMadeRun(), "MAC", GrossError{15.0, 0.5}, false)[0].gross, 3u);
}

TEST(ThresholdRows, FalseAcceptsAtEachThresholdFromOneRun) {
  const std::vector<ThresholdRow> rows =
      thresholdRows(handMadeRun(), "MAC", {0.0, 0.25, 0.5, 0.6, 0.9, 0.99}, GrossError{});
  ASSERT_EQ(rows.size(), 12u);  // 6 thresholds x 2 benchmarks, 3DMatch first
  EXPECT_EQ(rows[0].benchmark, "3DMatch");
  EXPECT_EQ(rows[6].benchmark, "3DLoMatch");
  struct Expected {
    std::size_t accepted, right, wrong, gross;
  };
  const Expected expected[] = {{7, 3, 4, 2}, {6, 3, 3, 1}, {5, 2, 3, 1},
                               {3, 2, 1, 1}, {1, 1, 0, 0}, {0, 0, 0, 0}};
  for (int k = 0; k < 6; ++k) {
    SCOPED_TRACE(rows[k].min_confidence);
    EXPECT_EQ(rows[k].pairs, 10u);
    EXPECT_EQ(rows[k].accepted, expected[k].accepted);
    EXPECT_EQ(rows[k].right, expected[k].right);
    EXPECT_EQ(rows[k].wrong, expected[k].wrong);
    EXPECT_EQ(rows[k].gross, expected[k].gross);
  }
  EXPECT_DOUBLE_EQ(rows[0].falseAcceptRate(), 4.0 / 7.0);
  EXPECT_DOUBLE_EQ(rows[0].recall(), 0.3);  // at 0: the recall without the verification
  EXPECT_DOUBLE_EQ(rows[3].falseAcceptRate(), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(rows[4].recall(), 0.1);
  EXPECT_DOUBLE_EQ(rows[5].falseAcceptRate(), 0.0);  // nothing accepted: nothing falsely

  // The run's own threshold gives back the paper table's successes and wrong ones.
  const PaperRow all = paperRows(handMadeRun(), "MAC", GrossError{}, false)[0];
  EXPECT_EQ(rows[2].accepted, all.successes);
  EXPECT_EQ(rows[2].wrong, all.wrong);
  EXPECT_EQ(rows[2].gross, all.gross);
  EXPECT_DOUBLE_EQ(rows[2].recall(), all.recall());
  EXPECT_EQ(rows[6].accepted, 2u);  // 3DLoMatch at 0: its unverified pose counts
  EXPECT_EQ(rows[8].accepted, 1u);
}

TEST(PaperTable, PrintsBothTablesAndMarksTheRunsThreshold) {
  const std::vector<PairOutcome> run = handMadeRun();
  std::ostringstream text;
  printPaperTable(text, paperRows(run, "MAC", GrossError{}, true),
                  thresholdRows(run, "MAC", {0.0, 0.5}, GrossError{}), 0.5, SuccessCriterion{}, GrossError{});
  const std::string table = text.str();
  EXPECT_NE(table.find("| 3DMatch | all 2 scenes | 10 | 20.00 % (2) | 1.50 | 3.00 |"), std::string::npos)
      << table;
  EXPECT_NE(table.find("| 30.00 % (3) | 5 | 3 (1) | 60.00 % |"), std::string::npos) << table;
  EXPECT_NE(table.find("| 3DMatch | **0.5** | 5 | 2 | 20.00 % | 3 (1) | 60.00 % |"), std::string::npos)
      << table;
  EXPECT_NE(table.find("| 3DMatch | 0 | 7 | 3 | 30.00 % | 4 (2) | 57.14 % |"), std::string::npos) << table;
  EXPECT_NE(table.find("| 3DMatch | hotel | 5 | 0.00 % (0) | - | - |"), std::string::npos) << table;

  std::ostringstream without_sweep;
  printPaperTable(without_sweep, paperRows(run, "MAC", GrossError{}, false), {}, 0.5, SuccessCriterion{},
                  GrossError{});
  EXPECT_EQ(without_sweep.str().find("min_confidence |"), std::string::npos);
}

TEST(PaperTable, TheCsvCarriesSceneConfidenceAndThePoseVerdict) {
  std::ostringstream csv;
  writeOutcomesCsv(csv, handMadeRun());
  const std::string text = csv.str();
  const std::string header = text.substr(0, text.find('\n'));
  EXPECT_EQ(header.rfind("pair,scene,subset,method,", 0), 0u) << header;
  EXPECT_NE(header.find(",status,confidence,"), std::string::npos);
  EXPECT_NE(header.find(",within_criterion,recalled,"), std::string::npos);
  // The unverified right pose: not recalled, but within the criterion, with its confidence.
  EXPECT_NE(text.find("\"kitchen pair\",\"kitchen\",\"3DMatch\",MAC,0,0,0,\"unverified\",0.3,3,0.06,1,0,"),
            std::string::npos)
      << text;
}

}  // namespace
}  // namespace mac_registration
