// The labelled evaluation's arithmetic on hand-made cases: what counts as a true and a false accept at a
// threshold, and the table and CSV it prints.
#include "verification_eval.hpp"

#include <gtest/gtest.h>

#include <sstream>

namespace mac_registration {
namespace {

VerificationCase labelled(bool answerable, bool registered, bool correct, double confidence) {
  VerificationCase c;
  c.name = "case";
  c.kind = "pair";
  c.answerable = c.has_truth = answerable;
  c.registered = registered;
  c.correct = correct;
  c.result.confidence = confidence;
  c.result.success = registered && confidence >= 0.5;
  return c;
}

TEST(OperatingPoint, CountsTrueAndFalseAcceptsAtAThreshold) {
  const std::vector<VerificationCase> cases = {
      labelled(true, true, true, 0.9),     // right, sure
      labelled(true, true, true, 0.4),     // right, unsure
      labelled(true, true, false, 0.6),    // a wrong pose of a positive, accepted at 0.5
      labelled(true, false, false, 0.0),   // nothing registered
      labelled(false, true, false, 0.55),  // a negative accepted at 0.5
      labelled(false, true, false, 0.1),   // a negative rejected
  };
  VerificationCase lucky = labelled(false, true, true, 0.8);  // a negative whose pose is right by chance
  lucky.has_truth = true;
  std::vector<VerificationCase> all = cases;
  all.push_back(lucky);

  const OperatingPoint p = operatingPoint(all, 0.5);
  EXPECT_EQ(p.positives, 4u);
  EXPECT_EQ(p.true_accepts, 1u);
  EXPECT_EQ(p.false_accepts, 2u);  // the wrong pose and the negative; the lucky one does no harm
  EXPECT_EQ(p.wrong_poses, 1u);
  EXPECT_EQ(p.wrong_accepted, 1u);
  EXPECT_EQ(p.negatives, 3u);
  EXPECT_EQ(p.negatives_accepted, 1u);
  EXPECT_DOUBLE_EQ(p.recall(), 0.25);
  EXPECT_NEAR(p.precision(), 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(p.falseAcceptRate(), 1.0 / 3.0, 1e-12);

  const OperatingPoint none = operatingPoint(all, 0.95);  // nothing accepted: precision is not at stake
  EXPECT_EQ(none.true_accepts + none.false_accepts, 0u);
  EXPECT_DOUBLE_EQ(none.precision(), 1.0);
  const OperatingPoint all_in = operatingPoint(all, 0.0);
  EXPECT_EQ(all_in.true_accepts, 2u);
  EXPECT_EQ(all_in.negatives_accepted, 2u);
}

TEST(OperatingPoint, PrintsOneRowPerThresholdAndTheCsvOnePerCase) {
  const std::vector<VerificationCase> cases = {labelled(true, true, true, 0.9),
                                               labelled(false, true, false, 0.2)};
  std::ostringstream table;
  printOperatingPoints(table, cases, {0.0, 0.5}, 0.5);
  EXPECT_NE(table.str().find("| 0.5 (preset) | 100.0 % | 100.0 % (1/1) | 0 | 0/0 | 0/1 (0.0 %) |"),
            std::string::npos)
      << table.str();
  EXPECT_NE(table.str().find("| 0 | 50.0 %"), std::string::npos) << table.str();
  std::ostringstream csv;
  writeVerificationCsv(csv, cases);
  std::size_t lines = 0;
  for (char ch : csv.str()) lines += ch == '\n';
  EXPECT_EQ(lines, 3u);  // header and two cases
  EXPECT_NE(csv.str().find("confidence"), std::string::npos);
}

}  // namespace
}  // namespace mac_registration
