// PCL's FPFH, in loops of its own around PCL's pair feature function. Every value that reaches a
// descriptor is PCL's to the bit: PCL's float operations (pcl/features/impl/fpfh.hpp, PCL 1.13), in PCL's
// order wherever the order can change a result. A fused multiply-add would round differently from PCL's
// compiled estimator, hence no contraction.
#include <omp.h>
#include <pcl/common/point_tests.h>
#include <pcl/features/pfh_tools.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mac_registration/features/fpfh.hpp"
#include "radius_search.hpp"

#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace mac_registration {
namespace {

constexpr int kBinsPerAngle = 11;  // PCL's default: 3 x 11 = the 33 bins of FPFHSignature33
constexpr int kBins = 3 * kBinsPerAngle;
constexpr int kRowStride = 36;  // a row padded to whole SIMD vectors

// The surface points some keypoint's neighbourhood holds, ascending: only their SPFH is ever weighted.
std::vector<int> neededSurfacePoints(const std::vector<Neighbourhood>& keypoint_hoods,
                                     std::size_t surface_size) {
  std::vector<char> needed(surface_size, 0);
  for (const auto& hood : keypoint_hoods) {
    for (const int s : hood.indices) needed[s] = 1;
  }
  std::vector<int> out;
  for (std::size_t s = 0; s < surface_size; ++s) {
    if (needed[s]) out.push_back(static_cast<int>(s));
  }
  return out;
}

// The surface as the aligned 4-vectors PCL's pair feature function takes.
struct PairInputs {
  std::vector<Eigen::Vector4f, Eigen::aligned_allocator<Eigen::Vector4f>> points, normals;
};

PairInputs pairInputs(const PointCloud& surface, const NormalCloud& normals) {
  PairInputs in;
  in.points.reserve(surface.size());
  in.normals.reserve(surface.size());
  for (std::size_t i = 0; i < surface.size(); ++i) {
    in.points.push_back(surface[i].getVector4fMap());
    in.normals.push_back(normals[i].getNormalVector4fMap());
  }
  return in;
}

// PCL's computePairFeatures takes as source the point whose normal is closer to the line between them
// (by the acos of the absolute cosines), so (p, q) and (q, p) give the same features bit for
// bit (every step is then the same float operation on the same values, negation being exact) unless the
// two acos round to the same float. That needs the two cosines within a few float roundings; this says
// whether they are within a margin far wider (the pair is then computed both ways).
bool sourceMayDependOnOrder(const Eigen::Vector4f& p, const Eigen::Vector4f& n_p, const Eigen::Vector4f& q,
                            const Eigen::Vector4f& n_q) {
  const Eigen::Vector3f d = (q - p).head<3>();
  const float scale = d.norm() * (n_p.head<3>().cwiseAbs().sum() + n_q.head<3>().cwiseAbs().sum());
  const float gap = std::fabs(std::fabs(n_p.head<3>().dot(d)) - std::fabs(n_q.head<3>().dot(d)));
  return !(gap > 1e-4f * scale);  // also when d is zero or anything is NaN
}

// PCL's bins of one pair feature (computePointSPFHSignature's arithmetic, in double as there).
struct PairBins {
  int b[3];
};

int clampBin(int h) { return h < 0 ? 0 : (h >= kBinsPerAngle ? kBinsPerAngle - 1 : h); }

PairBins pairBins(const PairInputs& in, int p, int q) {
  static const float d_pi = 1.0f / (2.0f * static_cast<float>(M_PI));  // FPFHEstimation's d_pi_
  float f1, f2, f3, f4;
  pcl::computePairFeatures(in.points[p], in.normals[p], in.points[q], in.normals[q], f1, f2, f3, f4);
  PairBins out;
  // PCL floors and then clamps below at 0: truncation differs from the floor only below 0, where both clamp.
  out.b[0] = clampBin(static_cast<int>(kBinsPerAngle * ((f1 + M_PI) * d_pi)));
  out.b[1] = clampBin(static_cast<int>(kBinsPerAngle * ((f2 + 1.0) * 0.5)));
  out.b[2] = clampBin(static_cast<int>(kBinsPerAngle * ((f3 + 1.0) * 0.5)));
  return out;
}

// One row of 33 floats per surface point (zero where unneeded), with the mask of its non-zero bins.
struct SpfhTable {
  std::vector<float> values;
  std::vector<std::uint64_t> nonzero;
  const float* row(int s) const { return values.data() + static_cast<std::size_t>(s) * kRowStride; }
};

// PCL's SPFH at every needed surface point. Each of its bins is PCL's increment 100 / (neighbours - 1)
// added once per pair feature falling there, a float sum of equal terms that does not depend on the
// order of the pairs: counting the pairs per bin and adding the increment that many times is PCL's value.
// A pair of two needed points is computed once for both (see sourceMayDependOnOrder); each thread
// counts into its own table, and the tables together stay within kCountTableBytes (fewer threads
// count on a surface too large for that).
constexpr double kCountTableBytes = 256.0 * 1024 * 1024;

SpfhTable computeSpfh(const PairInputs& in, const std::vector<Neighbourhood>& hoods,
                      const std::vector<int>& needed, int threads, const StopFlag* stop) {
  const std::size_t m = in.points.size();
  std::vector<char> is_needed(m, 0);
  for (const int s : needed) is_needed[s] = 1;
  const double table_bytes = static_cast<double>(m) * kBins * sizeof(std::uint32_t);
  const int counting_threads =
      static_cast<int>(std::max(1.0, std::min<double>(threads, kCountTableBytes / table_bytes)));
  std::vector<std::vector<std::uint32_t>> counts(counting_threads);
  const int count = static_cast<int>(needed.size());
#pragma omp parallel num_threads(counting_threads)
  {
    std::vector<std::uint32_t>& mine = counts[omp_get_thread_num()];
    mine.assign(m * kBins, 0);
    StopCheck check(stop);
#pragma omp for schedule(dynamic, 32)
    for (int j = 0; j < count; ++j) {
      if (check.stopped()) continue;
      const int p = needed[j];
      std::uint32_t* row_p = mine.data() + static_cast<std::size_t>(p) * kBins;
      for (const int q : hoods[p].indices) {
        if (q == p) continue;
        const bool both = is_needed[q];
        if (both && q < p) continue;  // counted from q's side
        const PairBins pq = pairBins(in, p, q);
        for (int a = 0; a < 3; ++a) ++row_p[a * kBinsPerAngle + pq.b[a]];
        if (!both) continue;
        const PairBins qp = sourceMayDependOnOrder(in.points[p], in.normals[p], in.points[q], in.normals[q])
                                ? pairBins(in, q, p)
                                : pq;
        std::uint32_t* row_q = mine.data() + static_cast<std::size_t>(q) * kBins;
        for (int a = 0; a < 3; ++a) ++row_q[a * kBinsPerAngle + qp.b[a]];
      }
    }
  }
  throwIfStopped(stop, "computing FPFH");
  SpfhTable table;
  table.values.assign(m * kRowStride, 0.0f);
  table.nonzero.assign(m, 0);
#pragma omp parallel num_threads(threads)
  {
    std::vector<float> repeated;  // repeated[k]: the increment added k times, as PCL's bins grow
    StopCheck check(stop);
#pragma omp for schedule(dynamic, 64)
    for (int j = 0; j < count; ++j) {
      const int p = needed[j];
      const std::size_t size = hoods[p].indices.size();
      if (size < 2 || check.stopped()) continue;
      const float increment = 100.0f / static_cast<float>(size - 1);
      repeated.assign(1, 0.0f);
      std::uint64_t mask = 0;
      float* values = table.values.data() + static_cast<std::size_t>(p) * kRowStride;
      for (int b = 0; b < kBins; ++b) {
        std::uint32_t k = 0;
        for (const auto& c : counts) {
          if (!c.empty()) k += c[static_cast<std::size_t>(p) * kBins + b];  // empty: a thread not started
        }
        while (repeated.size() <= k) repeated.push_back(repeated.back() + increment);
        values[b] = repeated[k];
        if (values[b] != 0.0f) mask |= std::uint64_t{1} << b;
      }
      table.nonzero[p] = mask;
    }
  }
  throwIfStopped(stop, "computing FPFH");
  return table;
}

// PCL's weightPointSPFHSignature at one keypoint, in its order: by neighbour, then by bin. A zero bin
// adds exactly nothing to PCL's float bins and double sums while the weight is finite (its weighted value
// is +0), so only the non-zero bins are visited.
void weightSequentially(const SpfhTable& table, const Neighbourhood& hood, float* histogram, double* sums) {
  std::fill(histogram, histogram + kBins, 0.0f);
  std::fill(sums, sums + 3, 0.0);
  for (std::size_t j = 0; j < hood.indices.size(); ++j) {
    if (hood.squared_distances[j] == 0) continue;  // the keypoint itself
    const float weight = 1.0f / hood.squared_distances[j];
    const float* row = table.row(hood.indices[j]);
    const std::uint64_t visit =
        std::isfinite(weight) ? table.nonzero[hood.indices[j]] : (std::uint64_t{1} << kBins) - 1;
    for (int a = 0; a < 3; ++a) {
      std::uint64_t bins = (visit >> (a * kBinsPerAngle)) & ((1u << kBinsPerAngle) - 1);
      while (bins != 0) {
        const int b = a * kBinsPerAngle + __builtin_ctzll(bins);
        bins &= bins - 1;
        const float value = row[b] * weight;
        sums[a] += value;
        histogram[b] += value;
      }
    }
  }
}

// The same with each bin's double sum on its own (vectorised across bins). PCL adds the weighted values
// one by one into a double per angle; no such addition rounds when the total stays below 2^52 units of
// the last place of the smallest non-zero value (every partial sum is then a whole number of those
// units below 2^53), and then any order gives PCL's sums. Returns false where that is not shown.
bool weightByBin(const SpfhTable& table, const Neighbourhood& hood, float* histogram, double* sums) {
  alignas(16) float bins[kRowStride] = {};
  double lanes[kRowStride] = {};
  float smallest = std::numeric_limits<float>::infinity();
  for (std::size_t j = 0; j < hood.indices.size(); ++j) {
    if (hood.squared_distances[j] == 0) continue;  // the keypoint itself
    const float weight = 1.0f / hood.squared_distances[j];
    if (!std::isfinite(weight)) return false;
    const float* row = table.row(hood.indices[j]);
#pragma omp simd reduction(min : smallest)
    for (int b = 0; b < kRowStride; ++b) {
      const float value = row[b] * weight;
      bins[b] += value;
      lanes[b] += value;
      smallest = std::min(smallest, value > 0.0f ? value : std::numeric_limits<float>::infinity());
    }
  }
  std::copy(bins, bins + kBins, histogram);
  for (int a = 0; a < 3; ++a) {
    sums[a] = 0.0;
    for (int b = a * kBinsPerAngle; b < (a + 1) * kBinsPerAngle; ++b) sums[a] += lanes[b];
  }
  if (smallest == std::numeric_limits<float>::infinity()) return true;  // all zero: exact
  if (!(smallest >= std::numeric_limits<float>::min())) return false;
  int exponent = 0;
  std::frexp(smallest, &exponent);  // smallest in [2^(exponent-1), 2^exponent): its ulp is 2^(exponent-24)
  const double limit = std::ldexp(1.0, exponent - 24 + 52);
  return sums[0] < limit && sums[1] < limit && sums[2] < limit;
}

void weightAt(const SpfhTable& table, const Neighbourhood& hood, pcl::FPFHSignature33& out) {
  if (hood.indices.empty()) {
    std::fill(std::begin(out.histogram), std::end(out.histogram), std::numeric_limits<float>::quiet_NaN());
    return;
  }
  float histogram[kBins];
  double sums[3];
  if (!weightByBin(table, hood, histogram, sums)) weightSequentially(table, hood, histogram, sums);
  for (int a = 0; a < 3; ++a) {
    const double factor = sums[a] != 0 ? 100.0 / sums[a] : sums[a];  // the bins of each angle sum to 100
    for (int b = a * kBinsPerAngle; b < (a + 1) * kBinsPerAngle; ++b)
      out.histogram[b] = static_cast<float>(histogram[b] * factor);
  }
}

int threadCount(int num_threads) { return num_threads > 0 ? num_threads : omp_get_num_procs(); }

}  // namespace

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& keypoints, const PointCloud::ConstPtr& surface,
                           const NormalCloud::ConstPtr& surface_normals, double radius, int num_threads,
                           const StopFlag* stop) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("FPFH radius must be a finite length > 0 m, got " + std::to_string(radius));
  const int threads = threadCount(num_threads);
  const CloudGrid grid = cloudGrid(*surface, radius);
  const std::vector<Neighbourhood> keypoint_hoods =
      searchAll(grid, *keypoints, allIndices(keypoints->size()), true, threads, stop);
  const bool same = keypoints == surface;
  // When the keypoints are the surface their lists serve both steps; else the SPFH step needs the
  // surface neighbours of the surface points the keypoints reach (PCL's setSearchSurface does the same).
  const std::vector<int> needed =
      same ? allIndices(surface->size()) : neededSurfacePoints(keypoint_hoods, surface->size());
  std::vector<Neighbourhood> surface_hoods;
  if (!same) surface_hoods = searchAll(grid, *surface, needed, false, threads, stop);
  const SpfhTable table = computeSpfh(pairInputs(*surface, *surface_normals),
                                      same ? keypoint_hoods : surface_hoods, needed, threads, stop);
  auto features = pcl::make_shared<FpfhCloud>();
  const int n = static_cast<int>(keypoints->size());
  features->resize(n);
  features->header = keypoints->header;
#pragma omp parallel num_threads(threads)
  {
    StopCheck check(stop);
#pragma omp for schedule(dynamic, 64)
    for (int k = 0; k < n; ++k) {
      if (!check.stopped()) weightAt(table, keypoint_hoods[k], (*features)[k]);
    }
  }
  throwIfStopped(stop, "computing FPFH");
  return features;
}

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads, const StopFlag* stop) {
  return computeFpfh(points, points, normals, radius, num_threads, stop);
}

bool isUsableDescriptor(const pcl::FPFHSignature33& descriptor) {
  float sum = 0.0f;
  for (const float bin : descriptor.histogram) {
    if (!std::isfinite(bin)) return false;
    sum += bin;
  }
  return sum > 0.0f;
}

}  // namespace mac_registration
