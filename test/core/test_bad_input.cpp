// Bad input must end in an explicit failure (or an honest success), within bounded time and memory, and
// never in a crash, a NaN pose or an uninitialized one.
#include <gtest/gtest.h>

#include <algorithm>

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "test_support.hpp"

namespace mac_registration {
namespace {

CorrespondenceSet randomRigidSet(int n, unsigned seed) {
  return makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(n, 1.0, seed)).correspondences;
}

void expectFailure(const MacResult& result, RegistrationStatus status) {
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.status, status) << "got " << toString(result.status) << ": " << result.message;
  EXPECT_FALSE(result.message.empty());
  EXPECT_TRUE(result.T_target_source.isApprox(Eigen::Isometry3d::Identity()));
}

TEST(BadInput, RaisedStopFlagCancelsWithoutAPose) {
  const StopFlag stop{true};
  const MacResult result = registerCorrespondences(randomRigidSet(200, 3), test::roomScaleParams(), &stop);
  expectFailure(result, RegistrationStatus::kCancelled);
}

// Registers on this thread while another raises the flag once the registration is under way (100 ms: far
// less than either case takes, whatever the machine), as a shutdown would.
MacResult registerAndStopMidway(const CorrespondenceSet& c, const MacParams& params) {
  StopFlag stop{false};
  std::thread stopper([&stop] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop = true;
  });
  const MacResult result = registerCorrespondences(c, params, &stop);
  stopper.join();
  return result;
}

TEST(BadInput, StopFlagRaisedDuringALongRegistrationCancelsIt) {
  // 200 000 correspondences with edges so short that no pair is compatible: the first-order pass tests
  // all 2e10 pairs, tens of seconds unless the flag ends it.
  const CorrespondenceSet large =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(200000, 0.05, 5)).correspondences;
  MacParams sparse = test::roomScaleParams();
  sparse.graph.gaussian_sigma = 1e-6;
  sparse.graph.max_correspondences = 0;  // no bound
  expectFailure(registerAndStopMidway(large, sparse), RegistrationStatus::kCancelled);

  // The same set with its usual thresholds: a dense consensus, stopped in whichever stage it has reached.
  expectFailure(registerAndStopMidway(large, test::roomScaleParams()), RegistrationStatus::kCancelled);

  // Nothing is left behind: the next registration succeeds.
  const MacResult after = registerCorrespondences(randomRigidSet(200, 3), test::roomScaleParams());
  EXPECT_TRUE(after.success) << after.message;
}

TEST(BadInput, FewerThanThreeCorrespondences) {
  for (int n : {0, 1, 2}) {
    CorrespondenceSet c;
    c.source_points = Eigen::Matrix3Xd::Random(3, n);
    c.target_points = c.source_points;
    expectFailure(registerCorrespondences(c, MacParams{}), RegistrationStatus::kTooFewCorrespondences);
  }
}

TEST(BadInput, MismatchedSourceAndTargetCounts) {
  CorrespondenceSet c;
  c.source_points = Eigen::Matrix3Xd::Random(3, 10);
  c.target_points = Eigen::Matrix3Xd::Random(3, 9);
  expectFailure(registerCorrespondences(c, MacParams{}), RegistrationStatus::kInvalidInput);
}

TEST(BadInput, InvalidParametersNameTheParameter) {
  MacParams params;
  params.graph.t_cmp = 1.5;
  params.evaluation.inlier_threshold = -1.0;
  const MacResult result = registerCorrespondences(randomRigidSet(50, 1), params);
  expectFailure(result, RegistrationStatus::kInvalidParameters);
  EXPECT_NE(result.message.find("graph.t_cmp"), std::string::npos);
  EXPECT_NE(result.message.find("evaluation.inlier_threshold"), std::string::npos);

  params = MacParams{};
  params.graph.max_correspondences = 999;
  const MacResult capped = registerCorrespondences(randomRigidSet(50, 1), params);
  expectFailure(capped, RegistrationStatus::kInvalidParameters);
  EXPECT_NE(capped.message.find("graph.max_correspondences"), std::string::npos);
}

bool hasWarningAbout(const MacResult& result, const std::string& parameter) {
  for (const auto& warning : result.warnings) {
    if (warning.find(parameter) != std::string::npos) return true;
  }
  return false;
}

TEST(BadInput, LargeEasySetRegistersOnASubset) {
  // 300 000 correspondences, 5 % inliers: the pair test runs on 50 000 of them (2 500 inliers), whose
  // consensus is still far over graph.max_edges and reduced to the correspondences of highest degree.
  const SyntheticProblem problem =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(300000, 0.05, 21));
  const MacResult result = registerCorrespondences(problem.correspondences, test::roomScaleParams());
  ASSERT_TRUE(result.success) << toString(result.status) << ": " << result.message;
  EXPECT_TRUE(result.graph_reduced);
  EXPECT_TRUE(hasWarningAbout(result, "graph.max_correspondences"));
  EXPECT_TRUE(hasWarningAbout(result, "graph.max_edges"));
  EXPECT_GT(result.counters.inliers, 14000u);  // of 15 000, counted over all 300 000
  EXPECT_LT(rotationErrorDeg(result.T_target_source, problem.T_target_source), 0.5);
  EXPECT_LT(translationError(result.T_target_source, problem.T_target_source), 0.01);
}

TEST(BadInput, LargeSparseSetEndsOnASubset) {
  // 200 000 correspondences of which no pair is compatible: the pair test is bounded to 50 000 of them
  // (1.25e9 pairs instead of 2e10), and the answer is an explicit empty graph.
  const CorrespondenceSet c =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(200000, 0.05, 23)).correspondences;
  MacParams params = test::roomScaleParams();
  params.graph.gaussian_sigma = 1e-6;
  const MacResult result = registerCorrespondences(c, params);
  expectFailure(result, RegistrationStatus::kEmptyGraph);
  EXPECT_EQ(result.counters.graph_nodes, 50000u);
  EXPECT_TRUE(hasWarningAbout(result, "graph.max_correspondences"));
}

TEST(BadInput, AllPointsEqualIsDegenerate) {
  CorrespondenceSet c;
  c.source_points = Eigen::Matrix3Xd::Constant(3, 50, 1.0);
  c.target_points = Eigen::Matrix3Xd::Constant(3, 50, 2.0);
  expectFailure(registerCorrespondences(c, MacParams{}), RegistrationStatus::kNoValidHypothesis);
}

TEST(BadInput, CollinearPointsAreDegenerate) {
  CorrespondenceSet c;
  c.source_points.resize(3, 40);
  for (int i = 0; i < 40; ++i) c.source_points.col(i) = Eigen::Vector3d(0.1 * i, 0.2 * i, -0.05 * i);
  c.target_points =
      (Eigen::Translation3d(1, 2, 3) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())) * c.source_points;
  expectFailure(registerCorrespondences(c, MacParams{}), RegistrationStatus::kNoValidHypothesis);
}

TEST(BadInput, NonFiniteCorrespondencesAreDroppedAndCounted) {
  SyntheticProblem problem = makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(300, 0.3, 3));
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  problem.correspondences.source_points(0, 5) = nan;
  problem.correspondences.target_points(2, 17) = inf;
  problem.correspondences.target_points(1, 18) = -inf;
  const MacResult result = registerCorrespondences(problem.correspondences, test::roomScaleParams());
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_EQ(result.counters.dropped_non_finite, 3u);
  EXPECT_TRUE(result.T_target_source.matrix().allFinite());
  // Inlier indices refer to the caller's columns, so the dropped ones never appear.
  for (int i : result.inlier_indices) EXPECT_TRUE(i != 5 && i != 17 && i != 18);
  EXPECT_LT(rotationErrorDeg(result.T_target_source, problem.T_target_source), 2.0);
}

TEST(BadInput, AllNonFiniteIsTooFew) {
  CorrespondenceSet c;
  c.source_points = Eigen::Matrix3Xd::Constant(3, 20, std::numeric_limits<double>::quiet_NaN());
  c.target_points = Eigen::Matrix3Xd::Zero(3, 20);
  const MacResult result = registerCorrespondences(c, MacParams{});
  expectFailure(result, RegistrationStatus::kTooFewCorrespondences);
  EXPECT_EQ(result.counters.dropped_non_finite, 20u);
}

TEST(BadInput, GraphWithoutEdges) {
  // Target distances are 10x the source ones: no pair is rigidly compatible.
  CorrespondenceSet c = randomRigidSet(100, 5);
  c.target_points = 10.0 * c.source_points;
  expectFailure(registerCorrespondences(c, MacParams{}), RegistrationStatus::kEmptyGraph);
}

TEST(BadInput, AllOutliersEndsExplicitly) {
  const SyntheticProblem problem = makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(1000, 0.0, 9));
  MacParams params = test::roomScaleParams();
  params.evaluation.min_inliers = 10;  // a robot would not accept a pose on fewer
  const MacResult result = registerCorrespondences(problem.correspondences, params);
  EXPECT_TRUE(result.T_target_source.matrix().allFinite());
  if (result.success) {
    EXPECT_GE(result.counters.inliers, 10u);
  } else {
    EXPECT_FALSE(result.message.empty());
  }
}

// The case that makes a plain enumeration explode: 50 % inliers with 1 mm noise on 1000 correspondences
// (the authors' code: 5.25 M maximal cliques, 12.8 GB). Here the bounds must hold and the pose be right.
TEST(BadInput, CleanHighInlierSetStaysBounded) {
  SyntheticSpec spec = test::roomScaleSpec(1000, 0.5, 13);
  spec.noise_sigma = 0.001;
  const SyntheticProblem problem = makeSyntheticProblem(test::bunnyMesh(), spec);
  MacParams params = test::roomScaleParams();
  params.cliques.max_cliques = 20000;
  params.cliques.time_limit = 1.0;
  const MacResult result = registerCorrespondences(problem.correspondences, params);
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_LE(result.counters.cliques,
            params.cliques.max_cliques * static_cast<std::size_t>(params.cliques.max_pruning_rounds + 1));
  EXPECT_LE(result.counters.selected_cliques, problem.correspondences.size());
  // The 500 inliers form a near-clique of degeneracy far above the bound: thinned, and reported.
  EXPECT_GT(result.counters.degeneracy, params.cliques.max_degeneracy);
  EXPECT_GT(result.counters.thinned_nodes, 0u);
  EXPECT_FALSE(result.warnings.empty());
  EXPECT_LT(rotationErrorDeg(result.T_target_source, problem.T_target_source), 2.0);
  EXPECT_LT(translationError(result.T_target_source, problem.T_target_source), 0.05);
}

TEST(BadInput, CountBoundIsReportedAsIncompleteSearch) {
  const SyntheticProblem problem =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(1000, 0.1, 17));
  MacParams params = test::roomScaleParams();
  params.graph.dense_mean_degree = 0.0;  // no cut of the chance edges: ~13 000 maximal cliques on this set
  params.cliques.max_cliques = 10;
  params.cliques.max_pruning_rounds = 0;
  const MacResult result = registerCorrespondences(problem.correspondences, params);
  EXPECT_FALSE(result.clique_search_complete);
  EXPECT_EQ(result.counters.cliques, 10u);
  // The bound's warning (a pose from 10 cliques may draw others after it, e.g. a planar consensus).
  EXPECT_TRUE(std::any_of(result.warnings.begin(), result.warnings.end(), [](const std::string& w) {
    return w.find("cliques.max_cliques") != std::string::npos;
  }));

  // Pruned until a search completes: still not the whole graph's cliques, and said so.
  params.cliques.max_cliques = 2000;
  params.cliques.max_pruning_rounds = 10;
  params.cliques.pruning_keep_fraction = 0.1;
  const MacResult pruned = registerCorrespondences(problem.correspondences, params);
  EXPECT_GT(pruned.counters.pruning_rounds, 0);
  EXPECT_FALSE(pruned.clique_search_complete);
  ASSERT_FALSE(pruned.warnings.empty());
  EXPECT_NE(pruned.warnings.back().find("cliques.max_cliques = 2000"), std::string::npos)
      << pruned.warnings.back();
  EXPECT_NE(pruned.warnings.back().find("complete"), std::string::npos) << pruned.warnings.back();
}

// A clique search that its time limit cuts off before it finds a clique fails as "no clique", but says the
// bound did it, not the data: the same set has cliques given the time.
TEST(BadInput, ATimeLimitThatFindsNoCliqueSaysSo) {
  const SyntheticProblem problem =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(1000, 0.1, 17));
  MacParams params = test::roomScaleParams();
  params.cliques.time_limit = 1e-9;  // spent before igraph starts
  const MacResult cut = registerCorrespondences(problem.correspondences, params);
  expectFailure(cut, RegistrationStatus::kNoClique);
  EXPECT_FALSE(cut.clique_search_complete);
  EXPECT_EQ(cut.counters.cliques, 0u);
  EXPECT_NE(cut.message.find("hit cliques.time_limit = 1e-09 s"), std::string::npos) << cut.message;
  EXPECT_NE(cut.message.find("raise cliques.time_limit"), std::string::npos) << cut.message;

  const MacResult given_time = registerCorrespondences(problem.correspondences, test::roomScaleParams());
  EXPECT_TRUE(given_time.success) << given_time.message;
  EXPECT_TRUE(given_time.clique_search_complete);
}

// A graph over the second-order budget is cut to its highest-degree nodes while the first-order graph is
// built; the result says so once, and counts the nodes kept.
TEST(BadInput, SecondOrderBudgetIsReportedOnce) {
  const SyntheticProblem problem =
      makeSyntheticProblem(test::bunnyMesh(), test::roomScaleSpec(1000, 0.5, 17));
  MacParams params = test::roomScaleParams();
  params.graph.max_second_order_work = 1e5;
  const MacResult result = registerCorrespondences(problem.correspondences, params);
  EXPECT_TRUE(result.graph_reduced);
  EXPECT_LT(result.counters.graph_nodes, 1000u);
  EXPECT_GT(result.counters.graph_nodes, 3u);
  const auto warns = std::count_if(result.warnings.begin(), result.warnings.end(), [](const std::string& w) {
    return w.find("graph.max_second_order_work") != std::string::npos;
  });
  EXPECT_EQ(warns, 1);
  EXPECT_NE(std::find_if(result.warnings.begin(), result.warnings.end(),
                         [&](const std::string& w) {
                           return w.find("kept the " + std::to_string(result.counters.graph_nodes)) !=
                                  std::string::npos;
                         }),
            result.warnings.end());
}

}  // namespace
}  // namespace mac_registration
