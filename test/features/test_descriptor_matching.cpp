// The exact brute-force descriptor search against FLANN's exact kd-tree (the search it replaces for
// features.match_epsilon = 0): on FPFH of shipped 3DMatch fragments and on random descriptors with planted
// duplicates (exact ties), its own nearest, second nearest and reverse nearest, and the matches built on
// them.
#include <gtest/gtest.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/features/feature_matching.hpp"

namespace mac_registration {
namespace {

// The squared distance as FLANN's L2_Simple sums it: bin by bin, in float.
float squaredDistance(const pcl::FPFHSignature33& a, const pcl::FPFHSignature33& b) {
  float sum = 0.0f;
  for (int i = 0; i < 33; ++i) {
    const volatile float diff = a.histogram[i] - b.histogram[i];  // volatile: no fused multiply-add
    const volatile float square = diff * diff;
    sum = sum + square;
  }
  return sum;
}

FpfhCloud::Ptr describedFragment(const std::string& path) {
  const PointCloud::Ptr cloud = loadCloud(path);
  return describeCloud(*cloud, FeatureParams{}, path).descriptors;
}

struct Fragments {
  FpfhCloud::Ptr f0 = describedFragment(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/target_cloud_bin_0.pcd");
  FpfhCloud::Ptr f4 = describedFragment(std::string(MAC_DATA_DIR) + "/redkitchen_4_0/source_cloud_bin_4.pcd");
  FpfhCloud::Ptr f21 = describedFragment(std::string(MAC_TEST_DATA_DIR) + "/redkitchen_21/cloud_bin_21.pcd");
};

const Fragments& fragments() {
  static const Fragments f;
  return f;
}

// Random histograms (bins 0..100 on a coarse grid, so that partial sums collide too) with copies of some
// targets among the targets and among the queries: exact ties for the nearest and the second nearest.
struct TiedSets {
  FpfhCloud::Ptr queries{new FpfhCloud};
  FpfhCloud::Ptr targets{new FpfhCloud};
};

TiedSets tiedSets(int queries, int targets, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> bin(0, 20);
  const auto randomHistogram = [&] {
    pcl::FPFHSignature33 h;
    for (float& v : h.histogram) v = 5.0f * static_cast<float>(bin(random));
    return h;
  };
  TiedSets s;
  for (int t = 0; t < targets; ++t) {
    // Every fifth target repeats an earlier one (a later index at the same distance from everything).
    if (t >= 10 && t % 5 == 0) {
      s.targets->push_back((*s.targets)[std::uniform_int_distribution<int>(0, t - 1)(random)]);
    } else {
      s.targets->push_back(randomHistogram());
    }
  }
  for (int q = 0; q < queries; ++q) {
    // Every third query is a copy of a target (distance 0, and a tie when that target has a copy).
    if (q % 3 == 0) {
      s.queries->push_back((*s.targets)[std::uniform_int_distribution<int>(0, targets - 1)(random)]);
    } else {
      s.queries->push_back(randomHistogram());
    }
  }
  return s;
}

// Compares the brute force with the exact kd-tree on every query: distances bit for bit, the index the
// same unless another target lies at exactly that distance, in which case the brute force has the lowest.
// Returns how many queries had a tie for their nearest.
int expectSameAsExactKdTree(const FpfhCloud::ConstPtr& queries, const FpfhCloud::ConstPtr& targets) {
  const DescriptorIndex index(targets);
  const auto brute = nearestDescriptorsBruteForce(*queries, index, 2);
  const auto tree = nearestDescriptorsKdTree(*queries, nullptr, index, 2, 0.0, 2);
  EXPECT_EQ(brute.size(), queries->size());
  int ties = 0;
  for (std::size_t q = 0; q < queries->size(); ++q) {
    SCOPED_TRACE("query " + std::to_string(q));
    EXPECT_EQ(brute[q].nearest_distance, tree[q].nearest_distance);  // bit for bit
    EXPECT_EQ(brute[q].second_distance, tree[q].second_distance);
    const float nearest2 = squaredDistance((*queries)[q], (*targets)[brute[q].nearest]);
    EXPECT_EQ(std::sqrt(nearest2), brute[q].nearest_distance);
    int lowest_at_nearest = -1;
    for (int t = 0; t < static_cast<int>(targets->size()) && lowest_at_nearest < 0; ++t)
      if (squaredDistance((*queries)[q], (*targets)[t]) == nearest2) lowest_at_nearest = t;
    EXPECT_EQ(brute[q].nearest, lowest_at_nearest);
    if (brute[q].nearest != tree[q].nearest) {
      // Only a tie may pick another target.
      EXPECT_EQ(squaredDistance((*queries)[q], (*targets)[tree[q].nearest]), nearest2);
    }
    if (brute[q].second_distance == brute[q].nearest_distance) ++ties;
  }
  return ties;
}

TEST(BruteForceSearch, EqualsTheExactKdTreeOnRealFragments) {
  const Fragments& f = fragments();
  ASSERT_GT(f.f0->size(), 1000u);
  EXPECT_EQ(expectSameAsExactKdTree(f.f4, f.f0), 0);
  EXPECT_EQ(expectSameAsExactKdTree(f.f21, f.f4), 0);
  expectSameAsExactKdTree(f.f0, f.f0);  // every query at distance 0 from itself
}

TEST(BruteForceSearch, EqualsTheExactKdTreeWithTiesToTheLowestIndex) {
  for (const unsigned seed : {1u, 2u}) {
    // Sizes off the tile width: a partial last tile of targets and a short last group of queries.
    const TiedSets s = tiedSets(203, 157, seed);
    EXPECT_GT(expectSameAsExactKdTree(s.queries, s.targets), 5);  // else the ties test nothing
  }
}

TEST(BruteForceSearch, OneReferenceDescriptorHasNoSecond) {
  const TiedSets s = tiedSets(7, 1, 3);
  const DescriptorIndex index(s.targets);
  for (const NearestDescriptors& n : nearestDescriptorsBruteForce(*s.queries, index, 1)) {
    EXPECT_EQ(n.nearest, 0);
    EXPECT_TRUE(std::isfinite(n.nearest_distance));
    EXPECT_TRUE(std::isinf(n.second_distance));
  }
}

TEST(BruteForceSearch, ReverseNearestIsEachTargetsNearestQueryWithTiesToTheLowest) {
  const Fragments& f = fragments();
  const TiedSets tied = tiedSets(211, 149, 4);
  for (const auto& [queries, targets] :
       {std::make_pair(FpfhCloud::ConstPtr(f.f4), FpfhCloud::ConstPtr(f.f0)),
        std::make_pair(FpfhCloud::ConstPtr(tied.queries), FpfhCloud::ConstPtr(tied.targets))}) {
    const DescriptorIndex target_index(targets), query_index(queries);
    std::vector<NearestDescriptors> reverse;
    nearestDescriptorsBruteForce(*queries, target_index, 2, &reverse);
    const auto tree = nearestDescriptorsKdTree(*targets, nullptr, query_index, 1, 0.0, 2);
    ASSERT_EQ(reverse.size(), targets->size());
    for (std::size_t t = 0; t < targets->size(); ++t) {
      SCOPED_TRACE("target " + std::to_string(t));
      ASSERT_EQ(reverse[t].nearest_distance, tree[t].nearest_distance);
      const float d2 = squaredDistance((*targets)[t], (*queries)[reverse[t].nearest]);
      int lowest = -1;
      for (int q = 0; q < static_cast<int>(queries->size()) && lowest < 0; ++q)
        if (squaredDistance((*targets)[t], (*queries)[q]) == d2) lowest = q;
      EXPECT_EQ(reverse[t].nearest, lowest);
    }
  }
}

TEST(BruteForceSearch, OneAndTwoThreadsGiveTheSameResults) {
  const Fragments& f = fragments();
  const DescriptorIndex index(f.f0);
  std::vector<NearestDescriptors> reverse1, reverse2;
  const auto one = nearestDescriptorsBruteForce(*f.f4, index, 1, &reverse1);
  const auto two = nearestDescriptorsBruteForce(*f.f4, index, 2, &reverse2);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t q = 0; q < one.size(); ++q) {
    ASSERT_EQ(one[q].nearest, two[q].nearest);
    ASSERT_EQ(one[q].nearest_distance, two[q].nearest_distance);
    ASSERT_EQ(one[q].second_distance, two[q].second_distance);
  }
  ASSERT_EQ(reverse1.size(), reverse2.size());
  for (std::size_t t = 0; t < reverse1.size(); ++t) {
    ASSERT_EQ(reverse1[t].nearest, reverse2[t].nearest);
    ASSERT_EQ(reverse1[t].nearest_distance, reverse2[t].nearest_distance);
  }
}

// Without the reverse search the scan skips the tiles whose norms are too far from the queries'; with it
// every pair is scanned. Both must give every query the same two nearest, on real fragments, on sets
// with exact ties (and copies at distance 0) and on one thread or two.
void expectPrunedScanIsTheFullScan(const FpfhCloud& queries, const FpfhCloud::ConstPtr& targets) {
  const DescriptorIndex index(targets);
  std::vector<NearestDescriptors> reverse;
  const auto full = nearestDescriptorsBruteForce(queries, index, 1, &reverse);
  for (const int threads : {1, 2}) {
    const auto pruned = nearestDescriptorsBruteForce(queries, index, threads);
    ASSERT_EQ(pruned.size(), full.size());
    for (std::size_t q = 0; q < full.size(); ++q) {
      ASSERT_EQ(pruned[q].nearest, full[q].nearest) << "query " << q << ", " << threads << " threads";
      ASSERT_EQ(pruned[q].nearest_distance, full[q].nearest_distance) << "query " << q;
      ASSERT_EQ(pruned[q].second_distance, full[q].second_distance) << "query " << q;
    }
  }
}

TEST(BruteForceSearch, TheScanByNormIsTheScanOfEveryPair) {
  const Fragments& f = fragments();
  expectPrunedScanIsTheFullScan(*f.f4, f.f0);
  expectPrunedScanIsTheFullScan(*f.f21, f.f4);
  for (const unsigned seed : {1u, 2u, 3u}) {
    const TiedSets s = tiedSets(203, 157, seed);
    expectPrunedScanIsTheFullScan(*s.queries, s.targets);
  }
  // A NaN bin (never a match, and no norm to sort by) in a query and in a target.
  TiedSets s = tiedSets(203, 157, 4);
  (*s.queries)[5].histogram[7] = std::numeric_limits<float>::quiet_NaN();
  (*s.targets)[11].histogram[3] = std::numeric_limits<float>::quiet_NaN();
  expectPrunedScanIsTheFullScan(*s.queries, s.targets);
}

// The matches at eps 0 (brute force) against the matches at eps 0 built from the kd-tree's neighbours
// here: the same on real fragments (no ties there) for mutual on and off and the ratio test, 1 and 2
// threads.
std::vector<FeatureMatch> kdTreeMatches(const FpfhCloud::ConstPtr& source, const FpfhCloud::ConstPtr& target,
                                        const FeatureParams& params, MatchingStats& stats) {
  stats = MatchingStats{};
  const DescriptorIndex s(source), t(target);
  const auto forward = nearestDescriptorsKdTree(*source, nullptr, t, 2, 0.0, 1);
  const auto backward = nearestDescriptorsKdTree(*target, nullptr, s, 1, 0.0, 1);
  std::vector<FeatureMatch> matches;
  for (int q = 0; q < static_cast<int>(forward.size()); ++q) {
    const NearestDescriptors& n = forward[q];
    if (params.mutual_filter && backward[n.nearest].nearest != q) {
      ++stats.rejected_mutual;
      continue;
    }
    if (params.ratio_test > 0.0 && !(n.nearest_distance < params.ratio_test * n.second_distance)) {
      ++stats.rejected_ratio;
      continue;
    }
    matches.push_back({q, n.nearest, n.nearest_distance});
  }
  std::stable_sort(matches.begin(), matches.end(),
                   [](const FeatureMatch& a, const FeatureMatch& b) { return a.distance < b.distance; });
  if (matches.size() > params.max_correspondences) {
    stats.truncated = matches.size() - params.max_correspondences;
    matches.resize(params.max_correspondences);
  }
  return matches;
}

TEST(BruteForceSearch, MatchesEqualTheKdTreesForMutualAndRatioTest) {
  const Fragments& f = fragments();
  for (const bool mutual : {false, true}) {
    for (const double ratio : {0.0, 0.9}) {
      for (const int threads : {1, 2}) {
        FeatureParams params;
        params.mutual_filter = mutual;
        params.ratio_test = ratio;
        params.num_threads = threads;
        SCOPED_TRACE("mutual " + std::to_string(mutual) + ", ratio " + std::to_string(ratio) + ", threads " +
                     std::to_string(threads));
        MatchingStats expected_stats, stats;
        const auto expected = kdTreeMatches(f.f4, f.f0, params, expected_stats);
        const auto actual = matchFeatures(f.f4, f.f0, params, stats);
        ASSERT_EQ(actual.size(), expected.size());
        for (std::size_t k = 0; k < expected.size(); ++k) {
          ASSERT_EQ(actual[k].source, expected[k].source) << k;
          ASSERT_EQ(actual[k].target, expected[k].target) << k;
          ASSERT_EQ(actual[k].distance, expected[k].distance) << k;
        }
        EXPECT_EQ(stats.rejected_mutual, expected_stats.rejected_mutual);
        EXPECT_EQ(stats.rejected_ratio, expected_stats.rejected_ratio);
        EXPECT_EQ(stats.truncated, expected_stats.truncated);
        if (mutual) {
          EXPECT_GT(stats.rejected_mutual, 0u);
        }
        if (ratio > 0.0) {
          EXPECT_GT(stats.rejected_ratio, 0u);
        }
      }
    }
  }
}

TEST(BruteForceSearch, ExactMatchingPacksTheTargetAndLeavesTheSourceUnsearched) {
  const Fragments& f = fragments();
  const DescriptorIndex s(f.f4), t(f.f0);
  FeatureParams params;
  params.mutual_filter = true;  // the reverse nearest comes from the same scan
  MatchingStats stats;
  EXPECT_FALSE(matchFeatures(s, t, params, stats).empty());
  EXPECT_TRUE(t.built());
  EXPECT_FALSE(s.built());
  EXPECT_EQ(t.packed().count, static_cast<int>(f.f0->size()));
}

TEST(BruteForceSearch, ConcurrentMatchesShareOnePackedTarget) {
  const Fragments& f = fragments();
  const DescriptorIndex s(f.f4), t(f.f0);
  FeatureParams params;
  params.mutual_filter = true;
  params.num_threads = 1;
  MatchingStats stats;
  const auto expected = matchFeatures(f.f4, f.f0, params, stats);  // fresh indices
  constexpr int kMatches = 4;
  std::vector<std::vector<FeatureMatch>> results(kMatches);
  std::vector<std::thread> threads;
  for (int i = 0; i < kMatches; ++i) {
    threads.emplace_back([&, i] {
      MatchingStats own;
      results[i] = matchFeatures(s, t, params, own);  // the first packs the target, the others wait
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const auto& r : results) {
    ASSERT_EQ(r.size(), expected.size());
    for (std::size_t k = 0; k < r.size(); ++k) {
      ASSERT_EQ(r[k].source, expected[k].source);
      ASSERT_EQ(r[k].target, expected[k].target);
      ASSERT_EQ(r[k].distance, expected[k].distance);
    }
  }
}

}  // namespace
}  // namespace mac_registration
