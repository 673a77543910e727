// Every row of the kernel table (src/core/kernels/kernel_table.hpp) against the portable variants, in one
// process: the same outputs bit for bit on random inputs, for each instruction set this CPU runs (the
// others are skipped, and say so).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "kernels/kernel_table.hpp"
#include "mac_registration/core/mac_registration.hpp"

namespace mac_registration {
namespace kernels {
namespace {

// 64-byte aligned storage, as the library lays out the kernels' inputs.
template <typename T>
std::unique_ptr<T[], void (*)(void*)> aligned(std::size_t count) {
  const std::size_t bytes = (count * sizeof(T) + 63) / 64 * 64;
  return {static_cast<T*>(std::aligned_alloc(64, bytes == 0 ? 64 : bytes)), std::free};
}

}  // namespace

void PrintTo(KernelSet set, std::ostream* out) { *out << kernelSetName(set); }

namespace {

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

class KernelSets : public ::testing::TestWithParam<KernelSet> {
 protected:
  void SetUp() override {
    if (!cpuRuns(GetParam()))
      GTEST_SKIP() << "this CPU does not run the " << kernelSetName(GetParam()) << " set";
  }
  const KernelTable& row() const { return kernelTable(GetParam()); }
  const KernelTable& reference() const { return kernelTable(KernelSet::kPortable); }
};

// Points in structure-of-arrays layout, a correspondence's source in s*, its target in t*.
struct Points {
  int n;
  std::unique_ptr<float[], void (*)(void*)> sx, sy, sz, tx, ty, tz;
  explicit Points(int count)
      : n(count),
        sx(aligned<float>(count)),
        sy(aligned<float>(count)),
        sz(aligned<float>(count)),
        tx(aligned<float>(count)),
        ty(aligned<float>(count)),
        tz(aligned<float>(count)) {}
};

// Half the correspondences follow one rigid motion (a translation), the others are random: rows hold
// both passing and failing pairs.
Points randomPoints(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> coordinate(-2.0f, 2.0f), noise(-0.01f, 0.01f);
  Points p(n);
  for (int k = 0; k < n; ++k) {
    p.sx[k] = coordinate(rng), p.sy[k] = coordinate(rng), p.sz[k] = coordinate(rng);
    if (k % 2 == 0) {
      p.tx[k] = p.sx[k] + 1.0f + noise(rng), p.ty[k] = p.sy[k] + noise(rng), p.tz[k] = p.sz[k] + noise(rng);
    } else {
      p.tx[k] = coordinate(rng), p.ty[k] = coordinate(rng), p.tz[k] = coordinate(rng);
    }
  }
  return p;
}

struct Row {
  int found = 0;
  std::vector<int> candidates;
  std::vector<float> d2;
};

Row testRow(PairTest test, const Points& p, int i, float max_d2) {
  std::vector<float> scratch(p.n);
  Row row;
  row.candidates.assign(p.n + kPairTestSlack, -1);
  row.d2.assign(p.n + kPairTestSlack, 0.0f);
  row.found = test(p.sx.get(), p.sy.get(), p.sz.get(), p.tx.get(), p.ty.get(), p.tz.get(), i, p.n, max_d2,
                   scratch.data(), row.candidates.data(), row.d2.data());
  return row;
}

TEST_P(KernelSets, PairTestFindsThePortablePairs) {
  std::mt19937 rng(7);
  // Sizes around the 8- and 16-lane blocks, so that rows start and end at every offset within a block.
  for (const int n : {1, 2, 7, 8, 9, 15, 16, 17, 31, 33, 64, 100, 257}) {
    const Points p = randomPoints(n, rng);
    for (const float max_d2 : {0.0f, 1e-4f, 0.05f, 100.0f}) {
      for (int i = 0; i < n; ++i) {
        const Row expected = testRow(reference().pair_test.run, p, i, max_d2);
        const Row actual = testRow(row().pair_test.run, p, i, max_d2);
        ASSERT_EQ(actual.found, expected.found) << "n " << n << " row " << i << " max_d2 " << max_d2;
        for (int c = 0; c < expected.found; ++c) {
          ASSERT_EQ(actual.candidates[c], expected.candidates[c]) << "n " << n << " row " << i;
          ASSERT_TRUE(sameBits(actual.d2[c], expected.d2[c])) << "n " << n << " row " << i << " pair " << c;
        }
      }
    }
  }
}

TEST_P(KernelSets, CommonCountsArePopcountsOfTheAnd) {
  std::mt19937_64 rng(11);
  // Densities from sparse to full, and rows longer than the AVX2 count's 31 blocks of byte sums.
  for (const std::size_t words : {std::size_t(8), std::size_t(16), std::size_t(128), std::size_t(520)}) {
    for (const int density : {1, 8, 32, 64}) {
      std::vector<std::unique_ptr<std::uint64_t[], void (*)(void*)>> rows;
      for (int r = 0; r < 5; ++r) {
        rows.push_back(aligned<std::uint64_t>(words));
        for (std::size_t w = 0; w < words; ++w) {
          std::uint64_t bits = ~std::uint64_t(0);
          for (int keep = 64; keep > density; keep /= 2) bits &= rng();  // about density of 64 bits set
          rows.back()[w] = density == 64 ? ~std::uint64_t(0) : bits;
        }
      }
      const std::uint64_t* a = rows[0].get();
      const std::uint64_t* const b[4] = {rows[1].get(), rows[2].get(), rows[3].get(), rows[4].get()};
      std::int64_t expected[4], actual[4];
      reference().common_counts4.run(a, b, words, expected);
      row().common_counts4.run(a, b, words, actual);
      for (int k = 0; k < 4; ++k) {
        std::int64_t direct = 0;
        for (std::size_t w = 0; w < words; ++w) direct += __builtin_popcountll(a[w] & b[k][w]);
        EXPECT_EQ(expected[k], direct) << words << " words, density " << density;
        EXPECT_EQ(actual[k], direct) << words << " words, density " << density;
        EXPECT_EQ(row().common_count.run(a, b[k], words), direct) << words << " words, density " << density;
      }
    }
  }
}

TEST_P(KernelSets, BitTransposeSwapsRowsAndColumns) {
  std::mt19937_64 rng(5);
  for (int block = 0; block < 50; ++block) {
    std::uint64_t original[64], expected[64], actual[64];
    for (int r = 0; r < 64; ++r) original[r] = block == 0 ? (std::uint64_t(1) << r) | 1u : rng() & rng();
    std::copy(original, original + 64, expected);
    std::copy(original, original + 64, actual);
    reference().transpose_bits.run(expected);
    row().transpose_bits.run(actual);
    for (int r = 0; r < 64; ++r) {
      ASSERT_EQ(actual[r], expected[r]) << "block " << block << " row " << r;
      for (int c = 0; c < 64; ++c)
        ASSERT_EQ((expected[r] >> c) & 1u, (original[c] >> r) & 1u)
            << "block " << block << " (" << r << ", " << c << ")";
    }
  }
}

// Descriptors packed as DescriptorIndex::Packed lays them out: tiles of kBins x kLanes floats, +inf in the
// padding, with the squared norms and each slot's descriptor.
struct PackedDescriptors {
  int count = 0, tiles = 0;
  std::unique_ptr<float[], void (*)(void*)> values{nullptr, std::free};
  std::unique_ptr<float[], void (*)(void*)> norms{nullptr, std::free};
  std::vector<int> descriptor_of_slot;
};

std::vector<std::vector<float>> randomHistograms(int count, std::mt19937& rng) {
  std::gamma_distribution<float> bin(0.3f, 10.0f);  // FPFH-like: mostly small bins, a few large ones
  std::vector<std::vector<float>> h(count, std::vector<float>(kBins));
  for (auto& histogram : h) {
    for (float& b : histogram) b = bin(rng);
  }
  // Duplicates and near-duplicates, so that ties and the screen's margin are exercised.
  for (int i = 3; i < count; i += 7) h[i] = h[i - 3];
  for (int i = 5; i < count; i += 11) h[i][i % kBins] = std::nextafter(h[i - 5][i % kBins], 1e9f);
  return h;
}

PackedDescriptors pack(const std::vector<std::vector<float>>& h) {
  PackedDescriptors p;
  p.count = static_cast<int>(h.size());
  p.tiles = (p.count + kLanes - 1) / kLanes;
  const std::size_t lanes = std::size_t(p.tiles) * kLanes;
  p.values = aligned<float>(lanes * kBins);
  p.norms = aligned<float>(lanes);
  std::fill(p.values.get(), p.values.get() + lanes * kBins, std::numeric_limits<float>::infinity());
  std::fill(p.norms.get(), p.norms.get() + lanes, std::numeric_limits<float>::infinity());
  p.descriptor_of_slot.assign(lanes, -1);
  for (int i = 0; i < p.count; ++i) {
    const int tile = i / kLanes, lane = i % kLanes;
    float norm = 0.0f;
    for (int b = 0; b < kBins; ++b) {
      p.values[(std::size_t(tile) * kBins + b) * kLanes + lane] = h[i][b];
      norm += h[i][b] * h[i][b];
    }
    p.norms[i] = norm;
    p.descriptor_of_slot[i] = i;
  }
  return p;
}

// Each query's best two, and each target's nearest query (the mutual check's columns).
struct ScanOutcome {
  std::vector<BestTwo> best;
  std::vector<float> column_d2;
  std::vector<int> column_query;
};

ScanOutcome scanAll(ScanTiles scan, const std::vector<std::vector<float>>& queries,
                    const PackedDescriptors& p, bool columns) {
  ScanOutcome out;
  out.best.resize(queries.size());
  out.column_d2.assign(std::size_t(p.tiles) * kLanes, std::numeric_limits<float>::infinity());
  out.column_query.assign(out.column_d2.size(), -1);
  const int n = static_cast<int>(queries.size());
  for (int q = 0; q < n; q += kQueryGroup) {
    ScanState s;
    const int distinct = std::min(kQueryGroup, n - q);
    for (int k = 0; k < kQueryGroup; ++k) {
      const int i = q + std::min(k, distinct - 1);
      s.query[k] = queries[i].data();
      s.query_index[k] = i;
      s.best[k] = &out.best[i];
      float norm = 0.0f;
      for (const float b : queries[i]) norm += b * b;
      s.query_norm[k] = norm;
    }
    s.target_norms = p.norms.get();
    s.target_of_slot = p.descriptor_of_slot.data();
    s.column_d2 = columns ? out.column_d2.data() : nullptr;
    s.column_query = columns ? out.column_query.data() : nullptr;
    // Tiles in two ranges, as the matching scans them chunk by chunk.
    scan(s, p.values.get(), 0, p.tiles / 2, distinct);
    scan(s, p.values.get(), p.tiles / 2, p.tiles, distinct);
  }
  return out;
}

TEST_P(KernelSets, DescriptorScanKeepsThePortableDistances) {
  std::mt19937 rng(3);
  for (const int targets : {1, 16, 37, 300}) {
    const auto histograms = randomHistograms(targets, rng);
    const PackedDescriptors packed = pack(histograms);
    // Queries: some of the targets themselves (distance 0, ties) and new ones; a short last group.
    auto queries = randomHistograms(21, rng);
    for (int i = 0; i < 21; i += 4) queries[i] = histograms[i % targets];
    for (const bool columns : {false, true}) {
      const ScanOutcome expected = scanAll(reference().descriptor_scan.run, queries, packed, columns);
      const ScanOutcome actual = scanAll(row().descriptor_scan.run, queries, packed, columns);
      for (std::size_t q = 0; q < queries.size(); ++q) {
        ASSERT_EQ(actual.best[q].index, expected.best[q].index) << targets << " targets, query " << q;
        ASSERT_TRUE(sameBits(actual.best[q].first, expected.best[q].first))
            << targets << " targets, query " << q;
        ASSERT_TRUE(sameBits(actual.best[q].second, expected.best[q].second))
            << targets << " targets, query " << q;
      }
      if (!columns) continue;
      for (int t = 0; t < targets; ++t) {
        ASSERT_EQ(actual.column_query[t], expected.column_query[t]) << targets << " targets, target " << t;
        ASSERT_TRUE(sameBits(actual.column_d2[t], expected.column_d2[t]))
            << targets << " targets, target " << t;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(EveryRow, KernelSets, ::testing::ValuesIn(kAllKernelSets),
                         [](const ::testing::TestParamInfo<KernelSet>& info) {
                           return std::string(kernelSetName(info.param));
                         });

TEST(KernelTable, EachVariantIsWrittenForItsSetOrANarrowerOne) {
  for (const KernelSet set : kAllKernelSets) {
    const KernelTable& row = kernelTable(set);
    for (const KernelSet written_for :
         {row.pair_test.written_for, row.common_count.written_for, row.common_counts4.written_for,
          row.transpose_bits.written_for, row.descriptor_scan.written_for}) {
      EXPECT_LE(static_cast<int>(written_for), static_cast<int>(set)) << kernelSetName(set);
    }
  }
}

TEST(KernelTable, TheActiveSetRunsHereAndIsNamedInTheLogLine) {
  EXPECT_TRUE(cpuRuns(activeKernelSet()));
  const std::string line = kernelsInUse();
  EXPECT_EQ(line.rfind(kernelSetName(activeKernelSet()), 0), 0u) << line;
  EXPECT_NE(line.find("pair test"), std::string::npos) << line;
  EXPECT_NE(line.find("common-neighbour count"), std::string::npos) << line;
  EXPECT_NE(line.find("bit transpose"), std::string::npos) << line;
  EXPECT_NE(line.find("descriptor scan"), std::string::npos) << line;
}

TEST(KernelTable, TheEnvironmentNarrowsTheSet) {
  const char* narrowed = std::getenv("MAC_REGISTRATION_KERNELS");
  if (narrowed == nullptr || std::string(narrowed) != "portable")
    GTEST_SKIP() << "run with MAC_REGISTRATION_KERNELS=portable (ctest's test_kernels_narrowed)";
  EXPECT_EQ(activeKernelSet(), KernelSet::kPortable);
  EXPECT_EQ(kernelsInUse().rfind("portable (pair test portable", 0), 0u) << kernelsInUse();
}

}  // namespace
}  // namespace kernels
}  // namespace mac_registration
