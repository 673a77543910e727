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

// A surface point's neighbours within the radius (itself included), as PCL's kd-tree returns them.
struct Neighbourhood {
  std::vector<int> indices;
  std::vector<float> squared_distances;
};

// Ascending, by a radix sort over the bytes that differ between the keys: a comparison sort of the
// ~100 keys of a neighbourhood spends most of its time on mispredicted branches.
void sortKeys(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) {
  const std::size_t n = keys.size();
  if (n < 32) {
    std::sort(keys.begin(), keys.end());
    return;
  }
  std::uint64_t any = 0, all = ~std::uint64_t{0};
  for (const std::uint64_t k : keys) {
    any |= k;
    all &= k;
  }
  const std::uint64_t varying = any ^ all;
  scratch.resize(n);
  std::uint64_t* from = keys.data();
  std::uint64_t* to = scratch.data();
  for (int shift = 0; shift < 64; shift += 8) {
    if (((varying >> shift) & 0xffu) == 0) continue;
    std::uint32_t start[256] = {};
    for (std::size_t i = 0; i < n; ++i) ++start[(from[i] >> shift) & 0xffu];
    std::uint32_t sum = 0;
    for (std::uint32_t& s : start) {
      const std::uint32_t c = s;
      s = sum;
      sum += c;
    }
    for (std::size_t i = 0; i < n; ++i) to[start[(from[i] >> shift) & 0xffu]++] = from[i];
    std::swap(from, to);
  }
  if (from != keys.data()) std::copy(from, from + n, keys.data());
}

// Every surface point within a radius of a query, found in a uniform grid of cells at least as wide as
// the radius (the 27 cells around the query's own hold them all). The lists are exactly those of PCL's
// kd-tree: FLANN's float distance ((q - p)_x² + (q - p)_y²) + (q - p)_z², kept when below the float
// radius², ordered by distance and then by index (FLANN's sort). FLANN prunes subtrees by bounds summed
// in float, which could only drop a point within rounding of the radius; this visits every candidate.
class SurfaceGrid {
 public:
  SurfaceGrid(const PointCloud& surface, double radius)
      : squared_radius_(static_cast<float>(radius * radius)) {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    Eigen::Vector3f hi = -lo;
    std::size_t finite = 0;  // PCL's kd-tree leaves non-finite points out, and so does the grid
    for (const auto& p : surface) {
      if (!pcl::isFinite(p)) continue;
      lo = lo.cwiseMin(p.getVector3fMap());
      hi = hi.cwiseMax(p.getVector3fMap());
      ++finite;
    }
    origin_ = lo.cast<double>();
    Eigen::Vector3d extent = Eigen::Vector3d::Zero();
    if (finite > 0) extent = (hi - lo).cast<double>();
    // A margin over the radius keeps a neighbour within one cell of the query's cell despite the rounding
    // of the cell coordinates; a wider cell keeps spread-out clouds within four cells a point.
    cell_ = radius * 1.001;
    const double max_cells = 4.0 * static_cast<double>(surface.size()) + 64.0;
    while ((std::floor(extent.x() / cell_) + 1) * (std::floor(extent.y() / cell_) + 1) *
               (std::floor(extent.z() / cell_) + 1) >
           max_cells)
      cell_ *= 1.25;
    for (int a = 0; a < 3; ++a) dims_[a] = static_cast<int>(std::floor(extent[a] / cell_)) + 1;
    const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
    // Counting sort of the points by cell: each cell's points contiguous, in index order.
    start_.assign(cells + 1, 0);
    constexpr std::size_t kNoCell = std::numeric_limits<std::size_t>::max();
    std::vector<std::size_t> cell_of(surface.size(), kNoCell);
    for (std::size_t i = 0; i < surface.size(); ++i) {
      if (!pcl::isFinite(surface[i])) continue;
      cell_of[i] = cellIndex(cellOf(surface[i]));
      ++start_[cell_of[i] + 1];
    }
    for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    x_.resize(finite);
    y_.resize(finite);
    z_.resize(finite);
    indices_.resize(finite);
    for (std::size_t i = 0; i < surface.size(); ++i) {
      if (cell_of[i] == kNoCell) continue;
      const std::size_t slot = fill[cell_of[i]]++;
      x_[slot] = surface[i].x;
      y_[slot] = surface[i].y;
      z_[slot] = surface[i].z;
      indices_[slot] = static_cast<int>(i);
    }
  }

  // The neighbours of `query`, in PCL's order when `sorted` (the weighting sums in it), else in grid order
  // (enough where only the set counts). `keys` and `scratch` are scratch space.
  void search(const pcl::PointXYZ& query, bool sorted, Neighbourhood& out, std::vector<std::uint64_t>& keys,
              std::vector<std::uint64_t>& scratch) const {
    if (!pcl::isFinite(query)) {  // PCL gives such a keypoint no neighbours (a NaN descriptor)
      out.indices.clear();
      out.squared_distances.clear();
      return;
    }
    const Eigen::Vector3f q = query.getVector3fMap();
    const Eigen::Vector3i c = cellOf(query);
    std::size_t ranges[9][2], candidates = 0, count = 0;
    int rows = 0;
    for (int z = std::max(c.z() - 1, 0); z <= std::min(c.z() + 1, dims_[2] - 1); ++z) {
      for (int y = std::max(c.y() - 1, 0); y <= std::min(c.y() + 1, dims_[1] - 1); ++y, ++rows) {
        const std::size_t row = cellIndex(Eigen::Vector3i(0, y, z));
        ranges[rows][0] = start_[row + std::max(c.x() - 1, 0)];
        ranges[rows][1] = start_[row + std::min(c.x() + 1, dims_[0] - 1) + 1];
        candidates += ranges[rows][1] - ranges[rows][0];
      }
    }
    // Every candidate is written and only those within the radius advance the end: no branch to mispredict.
    keys.resize(candidates);
    for (int r = 0; r < rows; ++r) {
      for (std::size_t s = ranges[r][0]; s < ranges[r][1]; ++s) {
        const float dx = q.x() - x_[s], dy = q.y() - y_[s], dz = q.z() - z_[s];
        float d = 0.0f;
        d += dx * dx;
        d += dy * dy;
        d += dz * dz;
        std::uint32_t bits;
        std::memcpy(&bits, &d, sizeof bits);  // non-negative floats order as their bit patterns
        keys[count] = std::uint64_t{bits} << 32 | static_cast<std::uint32_t>(indices_[s]);
        count += d < squared_radius_;
      }
    }
    keys.resize(count);
    if (sorted) sortKeys(keys, scratch);
    out.indices.resize(keys.size());
    out.squared_distances.resize(keys.size());
    for (std::size_t j = 0; j < keys.size(); ++j) {
      out.indices[j] = static_cast<int>(keys[j] & 0xffffffffu);
      const auto bits = static_cast<std::uint32_t>(keys[j] >> 32);
      std::memcpy(&out.squared_distances[j], &bits, sizeof bits);
    }
  }

 private:
  Eigen::Vector3i cellOf(const pcl::PointXYZ& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      // A query outside the surface's box is clamped next to it: the distances decide.
      const double i = std::floor((static_cast<double>(p.data[a]) - origin_[a]) / cell_);
      c[a] = static_cast<int>(std::min(std::max(i, -1.0), static_cast<double>(dims_[a])));
    }
    return c;
  }
  std::size_t cellIndex(const Eigen::Vector3i& c) const {
    return (static_cast<std::size_t>(c.z()) * dims_[1] + c.y()) * dims_[0] + c.x();
  }

  float squared_radius_;  // PCL's KdTreeFLANN: static_cast<float>(radius * radius)
  Eigen::Vector3d origin_;
  double cell_ = 1.0;
  int dims_[3] = {1, 1, 1};
  std::vector<std::size_t> start_;  // cell c's points are slots start_[c] .. start_[c + 1] - 1
  std::vector<float> x_, y_, z_;
  std::vector<int> indices_;
};

std::vector<Neighbourhood> searchAll(const SurfaceGrid& grid, const PointCloud& queries,
                                     const std::vector<int>& which, bool sorted, int threads) {
  std::vector<Neighbourhood> out(queries.size());
  const int n = static_cast<int>(which.size());
#pragma omp parallel num_threads(threads)
  {
    std::vector<std::uint64_t> keys, scratch;
#pragma omp for schedule(dynamic, 64)
    for (int j = 0; j < n; ++j) grid.search(queries[which[j]], sorted, out[which[j]], keys, scratch);
  }
  return out;
}

std::vector<int> allIndices(std::size_t n) {
  std::vector<int> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<int>(i);
  return out;
}

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
                      const std::vector<int>& needed, int threads) {
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
#pragma omp for schedule(dynamic, 32)
    for (int j = 0; j < count; ++j) {
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
  SpfhTable table;
  table.values.assign(m * kRowStride, 0.0f);
  table.nonzero.assign(m, 0);
#pragma omp parallel num_threads(threads)
  {
    std::vector<float> repeated;  // repeated[k]: the increment added k times, as PCL's bins grow
#pragma omp for schedule(dynamic, 64)
    for (int j = 0; j < count; ++j) {
      const int p = needed[j];
      const std::size_t size = hoods[p].indices.size();
      if (size < 2) continue;
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
                           const NormalCloud::ConstPtr& surface_normals, double radius, int num_threads) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("FPFH radius must be a finite length > 0 m, got " + std::to_string(radius));
  const int threads = threadCount(num_threads);
  const SurfaceGrid grid(*surface, radius);
  const std::vector<Neighbourhood> keypoint_hoods =
      searchAll(grid, *keypoints, allIndices(keypoints->size()), true, threads);
  const bool same = keypoints == surface;
  // When the keypoints are the surface their lists serve both steps; else the SPFH step needs the
  // surface neighbours of the surface points the keypoints reach (PCL's setSearchSurface does the same).
  const std::vector<int> needed =
      same ? allIndices(surface->size()) : neededSurfacePoints(keypoint_hoods, surface->size());
  std::vector<Neighbourhood> surface_hoods;
  if (!same) surface_hoods = searchAll(grid, *surface, needed, false, threads);
  const SpfhTable table = computeSpfh(pairInputs(*surface, *surface_normals),
                                      same ? keypoint_hoods : surface_hoods, needed, threads);
  auto features = pcl::make_shared<FpfhCloud>();
  const int n = static_cast<int>(keypoints->size());
  features->resize(n);
  features->header = keypoints->header;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (int k = 0; k < n; ++k) weightAt(table, keypoint_hoods[k], (*features)[k]);
  return features;
}

FpfhCloud::Ptr computeFpfh(const PointCloud::ConstPtr& points, const NormalCloud::ConstPtr& normals,
                           double radius, int num_threads) {
  return computeFpfh(points, points, normals, radius, num_threads);
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
