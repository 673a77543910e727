#include "mac_registration/features/cloud_registration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/features/cloud_filtering.hpp"
#include "mac_registration/features/cloud_verification.hpp"
#include "mac_registration/features/feature_matching.hpp"
#include "mac_registration/features/fpfh.hpp"
#include "mac_registration/features/normals.hpp"
#include "mac_registration/features/resolution.hpp"
#include "mac_registration/features/voxel_downsampling.hpp"
#include "radius_search.hpp"

namespace mac_registration {
namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Keeps the entries of `cloud` at `indices`; the clouds stay unorganized.
template <typename Point>
typename pcl::PointCloud<Point>::Ptr subset(const pcl::PointCloud<Point>& cloud,
                                            const std::vector<int>& indices) {
  auto kept = pcl::make_shared<pcl::PointCloud<Point>>();
  kept->reserve(indices.size());
  for (const int i : indices) kept->push_back(cloud[i]);
  return kept;
}

// Refuses a finite cloud the voxel grid and the kd-trees cannot work on: coordinates beyond
// kMaxAbsCoordinate, or so far from the origin that float32 spaces them more than a quarter voxel apart
// (every voxel would hold a few quantized values, and normals and FPFH would describe that staircase).
void throwIfOutOfRange(const PointCloud& finite, double voxel_size, const std::string& role) {
  const std::string bound = coordinateBoundProblem(finite);
  if (!bound.empty()) throw std::invalid_argument(role + " cloud: " + bound);
  float largest = 0.0f;
  for (const auto& p : finite) largest = std::max({largest, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  const double spacing = double(std::nextafter(largest, std::numeric_limits<float>::infinity())) - largest;
  if (spacing > 0.25 * voxel_size) {
    std::ostringstream reason;
    reason << role << " cloud: its coordinates reach " << largest << " m, where float32 values are "
           << spacing << " m apart, more than a quarter of the voxel size (" << voxel_size
           << " m): shift the cloud to a local origin or raise features.voxel_size";
    throw std::invalid_argument(reason.str());
  }
}

// The indices of the finite normals.
std::vector<int> finiteNormals(const NormalCloud& normals) {
  std::vector<int> finite;
  for (int i = 0; i < static_cast<int>(normals.size()); ++i) {
    const auto& n = normals[i];
    if (std::isfinite(n.normal_x) && std::isfinite(n.normal_y) && std::isfinite(n.normal_z))
      finite.push_back(i);
  }
  return finite;
}

void throwIfInvalid(const FeatureParams& params) {
  const auto problems = validateFeatureParams(params);
  if (problems.empty()) return;
  std::string message = "invalid feature parameters:";
  for (const auto& p : problems) message += " " + p;
  throw std::invalid_argument(message);
}

// The cloud's own descriptor index while it still indexes its descriptors, else a new one for this match.
std::shared_ptr<const DescriptorIndex> indexOf(const DescribedCloud& cloud) {
  if (cloud.descriptor_index && cloud.descriptor_index->descriptors() == cloud.descriptors)
    return cloud.descriptor_index;
  return std::make_shared<const DescriptorIndex>(cloud.descriptors);
}

// The number of voxels of leaf `voxel` that hold a finite point of `cloud`.
std::size_t occupiedVoxels(const PointCloud& cloud, double voxel) {
  std::vector<std::uint64_t> keys;
  keys.reserve(cloud.size());
  const auto cell = [voxel](float v) {
    return std::uint64_t(std::int64_t(std::floor(v / voxel)) & 0x1fffff);
  };
  for (const auto& p : cloud) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      keys.push_back(cell(p.x) << 42 | cell(p.y) << 21 | cell(p.z));
  }
  std::sort(keys.begin(), keys.end());
  return std::size_t(std::unique(keys.begin(), keys.end()) - keys.begin());
}

// `params` with its auto voxel size (0) replaced by `voxel`.
FeatureParams withVoxel(FeatureParams params, double voxel) {
  if (params.voxel_size == 0.0) params.voxel_size = voxel;
  return params;
}

}  // namespace

double autoVoxelSize(const PointCloud& cloud, const StopFlag* stop) {
  std::size_t finite = 0;  // counted in place: a copy of the finite points would double a map's memory
  const double diagonal = finiteDiagonal(cloud, finite);
  if (finite < 3 || !(diagonal > 0.0)) return 0.0;
  const double wanted = double(std::min(kAutoVoxelKeypoints, std::max<std::size_t>(1, finite / 2)));
  // A surface holds voxels in proportion to 1 / leaf^2, so each step scales the leaf by the square root of
  // the miss; three steps from a hundredth of the diagonal land within a few per cent on scans, objects
  // and rooms alike. The leaf never goes below a millionth of the diagonal (the 21-bit keys above).
  double voxel = diagonal / 100.0;
  for (int step = 0; step < 3; ++step) {
    throwIfStopped(stop, "choosing the voxel size");  // each count sorts a key per point
    const double occupied = double(occupiedVoxels(cloud, voxel));
    voxel = std::max(diagonal * 1e-6, voxel * std::sqrt(occupied / wanted));
  }
  return voxel;
}

namespace {

// Keypoints whose K-th neighbour distance the support scale is the median of: an even subsample, as the
// median converges long before every keypoint of a dense scan is asked.
constexpr std::size_t kSupportScaleSamples = 1000;

// The median over the keypoints `which` of the distance to their `wanted`-th nearest keypoint (itself the
// first), or infinity where more than half have fewer than `wanted` within `reach` [m].
double medianReach(const PointCloud& keypoints, const std::vector<int>& which, std::size_t wanted,
                   double reach, int threads, const StopFlag* stop) {
  const CloudGrid grid = cloudGrid(keypoints, reach);
  const std::vector<Neighbourhood> found = searchAll(grid, keypoints, which, false, threads, stop);
  std::vector<double> reaches;
  reaches.reserve(which.size());
  for (const int i : which) {
    std::vector<float> squared = found[i].squared_distances;
    if (squared.size() < wanted) {
      reaches.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    std::nth_element(squared.begin(), squared.begin() + (wanted - 1), squared.end());
    reaches.push_back(std::sqrt(double(squared[wanted - 1])));
  }
  std::nth_element(reaches.begin(), reaches.begin() + reaches.size() / 2, reaches.end());
  return reaches[reaches.size() / 2];
}

// The factor both radii grow by so that the median keypoint's FPFH sphere holds
// params.min_feature_neighbours keypoints (itself included), rounded to a quarter octave (a cloud of
// steady density keeps one scale from scan to scan) and clamped to [1, kMaxSupportScale].
double supportScale(const PointCloud& keypoints, const FeatureParams& params, const StopFlag* stop) {
  const std::size_t wanted = params.min_feature_neighbours;
  if (wanted == 0 || keypoints.size() < wanted) return 1.0;
  std::vector<int> which;
  const std::size_t step = std::max<std::size_t>(1, keypoints.size() / kSupportScaleSamples);
  for (std::size_t i = 0; i < keypoints.size(); i += step) which.push_back(int(i));
  const double radius = params.feature_radius_factor * params.voxel_size;
  // Dense clouds hold them within the radius as given (up to where it would round to a step up): a search
  // of that radius settles it without a wider one.
  const double rounds_to_one = radius * std::exp2(0.125);
  if (medianReach(keypoints, which, wanted, rounds_to_one, params.num_threads, stop) <= rounds_to_one)
    return 1.0;
  const double needed =
      medianReach(keypoints, which, wanted, kMaxSupportScale * radius, params.num_threads, stop) / radius;
  if (!std::isfinite(needed)) return kMaxSupportScale;
  return std::clamp(std::exp2(std::round(4.0 * std::log2(needed)) / 4.0), 1.0, kMaxSupportScale);
}

}  // namespace

bool resolutionNeeded(const FeatureParams& params) { return params.gaussian_sigma_resolutions > 0.0; }

bool describedWith(const DescribedCloud& cloud, const FeatureParams& params) {
  return (params.voxel_size == 0.0 || cloud.params.voxel_size == params.voxel_size) &&
         cloud.params.normal_radius_factor == params.normal_radius_factor &&
         cloud.params.feature_radius_factor == params.feature_radius_factor &&
         cloud.params.min_feature_neighbours == params.min_feature_neighbours &&
         cloud.params.support_voxel_factor == params.support_voxel_factor;
}

namespace {

// describeCloud's stages, which throw Cancelled when `stop` ends them.
DescribedCloud describeStages(const PointCloud& cloud, const FeatureParams& given, const std::string& role,
                              const StopFlag* stop, double support_scale) {
  throwIfInvalid(given);
  const FeatureParams params = withVoxel(given, given.voxel_size == 0.0 ? autoVoxelSize(cloud, stop) : 0.0);
  DescribedCloud out;
  out.params = params;
  out.points = cloud.size();
  throwIfStopped(stop, "before the front end");
  const PointCloud::Ptr finite = finitePoints(cloud, out.dropped);
  if (finite->size() < 3) {
    throw std::invalid_argument(role + " cloud has " + std::to_string(finite->size()) +
                                " finite points (of " + std::to_string(cloud.size()) +
                                "); at least 3 are needed");
  }
  throwIfOutOfRange(*finite, params.voxel_size, role);
  throwIfStopped(stop, "checking the points");
  out.viewpoint = finite->sensor_origin_.head<3>();
  auto start = Clock::now();
  // The kd-tree over every raw point costs more than its queries (a quarter of the front end on a
  // 3DMatch fragment), and only the resolution-unit d_cmp needs the result.
  if (resolutionNeeded(params))
    out.resolution = meanNearestNeighbourDistance(finite, params.resolution_samples, stop);
  out.times.resolution_ms = millisecondsSince(start);

  start = Clock::now();
  PointCloud::Ptr voxels = voxelDownsample(*finite, params.voxel_size, params.num_threads, stop);
  out.voxels = voxels->size();
  out.support_scale = support_scale > 0.0 ? support_scale : supportScale(*voxels, params, stop);
  out.times.downsample_ms = millisecondsSince(start);

  start = Clock::now();
  const double normal_radius = out.support_scale * params.normal_radius_factor * params.voxel_size;
  const NormalCloud::Ptr normals = estimateNormals(voxels, normal_radius, params.num_threads, stop);
  // Points without a normal are left out of the FPFH neighbourhoods too: their pair features are undefined.
  const std::vector<int> with_normal = finiteNormals(*normals);
  voxels = subset(*voxels, with_normal);
  const NormalCloud::Ptr kept_normals = subset(*normals, with_normal);
  out.times.normals_ms = millisecondsSince(start);

  PointCloud::Ptr surface = voxels;
  NormalCloud::Ptr surface_normals = kept_normals;
  if (params.support_voxel_factor > 1.0) {
    start = Clock::now();
    surface =
        voxelDownsample(*voxels, params.support_voxel_factor * params.voxel_size, params.num_threads, stop);
    out.times.downsample_ms += millisecondsSince(start);
    start = Clock::now();
    // Fitted to the keypoints around each surface point, not to the few surface points themselves.
    const NormalCloud::Ptr fitted = estimateNormals(surface, voxels, normal_radius, params.num_threads, stop);
    const std::vector<int> fitted_finite = finiteNormals(*fitted);
    surface = subset(*surface, fitted_finite);
    surface_normals = subset(*fitted, fitted_finite);
    out.times.normals_ms += millisecondsSince(start);
  }
  out.support_points = surface->size();

  start = Clock::now();
  const FpfhCloud::Ptr descriptors = computeFpfh(
      voxels, surface, surface_normals, out.support_scale * params.feature_radius_factor * params.voxel_size,
      params.num_threads, stop);
  std::vector<int> usable;
  for (int i = 0; i < static_cast<int>(descriptors->size()); ++i) {
    if (isUsableDescriptor((*descriptors)[i])) usable.push_back(i);
  }
  out.keypoints = subset(*voxels, usable);
  out.normals = subset(*kept_normals, usable);
  out.descriptors = subset(*descriptors, usable);
  out.descriptor_index = std::make_shared<const DescriptorIndex>(out.descriptors);
  out.no_feature = out.voxels - usable.size();
  out.times.features_ms = millisecondsSince(start);
  out.times.total_ms = out.times.frontEndMs();
  return out;
}

}  // namespace

DescribedCloud describeCloud(const PointCloud& cloud, const FeatureParams& params, const std::string& role,
                             const StopFlag* stop, double support_scale) {
  try {
    return describeStages(cloud, params, role, stop, support_scale);
  } catch (const Cancelled& e) {
    throw Cancelled(std::string(e.what()) + " (describing the " + role + " cloud)");
  }
}

FeatureCorrespondences matchDescribedClouds(const DescribedCloud& s, const DescribedCloud& t,
                                            const FeatureParams& params, const StopFlag* stop) {
  throwIfInvalid(params);
  if (!describedWith(s, params) || !describedWith(t, params) || s.params.voxel_size != t.params.voxel_size) {
    throw std::invalid_argument(
        "the clouds were described with other voxel_size, radius or support factors than these");
  }
  if (s.support_scale != t.support_scale) {
    throw std::invalid_argument("the clouds were described at different support scales (" +
                                std::to_string(s.support_scale) + ", " + std::to_string(t.support_scale) +
                                "): describe the sparser one's scale on both");
  }
  FeatureCorrespondences out;
  FrontEndStats& stats = out.stats;
  stats.source_points = s.points;
  stats.target_points = t.points;
  stats.source_dropped = s.dropped;
  stats.target_dropped = t.dropped;
  stats.source_keypoints = s.voxels;
  stats.target_keypoints = t.voxels;
  stats.source_no_feature = s.no_feature;
  stats.target_no_feature = t.no_feature;
  stats.resolution = 0.5 * (s.resolution + t.resolution);
  stats.voxel_size = t.params.voxel_size;
  stats.support_scale = t.support_scale;
  stats.times = s.times;
  stats.times += t.times;

  const auto start = Clock::now();
  MatchingStats matching;
  throwIfStopped(stop, "before matching descriptors");
  const std::vector<FeatureMatch> matches = matchFeatures(*indexOf(s), *indexOf(t), params, matching, stop);
  stats.rejected_mutual = matching.rejected_mutual;
  stats.rejected_ratio = matching.rejected_ratio;
  stats.truncated = matching.truncated;

  CorrespondenceSet& c = out.correspondences;
  const auto n = static_cast<Eigen::Index>(matches.size());
  c.source_points.resize(3, n);
  c.target_points.resize(3, n);
  c.source_normals.resize(3, n);
  c.target_normals.resize(3, n);
  out.source_indices.resize(matches.size());
  out.target_indices.resize(matches.size());
  for (Eigen::Index k = 0; k < n; ++k) {
    const FeatureMatch& m = matches[k];
    c.source_points.col(k) = (*s.keypoints)[m.source].getVector3fMap().cast<double>();
    c.target_points.col(k) = (*t.keypoints)[m.target].getVector3fMap().cast<double>();
    c.source_normals.col(k) = (*s.normals)[m.source].getNormalVector3fMap().cast<double>();
    c.target_normals.col(k) = (*t.normals)[m.target].getNormalVector3fMap().cast<double>();
    out.source_indices[k] = m.source;
    out.target_indices[k] = m.target;
  }
  out.source_keypoints = s.keypoints;
  out.target_keypoints = t.keypoints;
  out.source_keypoint_normals = s.normals;
  out.target_keypoint_normals = t.normals;
  out.source_viewpoint = s.viewpoint;
  out.target_viewpoint = t.viewpoint;
  stats.times.matching_ms = millisecondsSince(start);
  stats.times.total_ms += stats.times.matching_ms;
  return out;
}

namespace {

// `described` (of `cloud`) described again at `scale`, its first description's time counted too.
void describeAgainAt(DescribedCloud& described, const PointCloud& cloud, double scale,
                     const std::string& role, const StopFlag* stop) {
  const StageTimes first = described.times;
  described = describeCloud(cloud, described.params, role, stop, scale);
  described.times += first;
}

// The sparser cloud's support scale on both (a pair's descriptors must be comparable).
void atCommonScale(DescribedCloud& s, const PointCloud& source, DescribedCloud& t, const PointCloud& target,
                   const StopFlag* stop) {
  const double common = std::max(s.support_scale, t.support_scale);
  if (s.support_scale != common) describeAgainAt(s, source, common, "source", stop);
  if (t.support_scale != common) describeAgainAt(t, target, common, "target", stop);
}

}  // namespace

FeatureCorrespondences computeCorrespondences(const PointCloud& source, const PointCloud& target,
                                              const FeatureParams& given, const StopFlag* stop) {
  // One leaf for both clouds (their descriptors must be comparable): the coarser, so that neither holds
  // more keypoints than the budget.
  const FeatureParams params =
      given.voxel_size == 0.0
          ? withVoxel(given, std::max(autoVoxelSize(source, stop), autoVoxelSize(target, stop)))
          : given;
  DescribedCloud s = describeCloud(source, params, "source", stop);
  DescribedCloud t = describeCloud(target, params, "target", stop);
  atCommonScale(s, source, t, target, stop);
  return matchDescribedClouds(s, t, params, stop);
}

MacParams inCloudUnits(const MacParams& mac_params, const FeatureParams& feature_params,
                       const FrontEndStats& stats) {
  MacParams params = mac_params;
  if (feature_params.gaussian_sigma_resolutions > 0.0 && stats.resolution > 0.0)
    params.graph.gaussian_sigma = feature_params.gaussian_sigma_resolutions * stats.resolution;
  const auto derive = [&](double& distance, double voxels) {
    if (distance == 0.0) distance = voxels * stats.voxel_size;
  };
  derive(params.graph.gaussian_sigma, kGaussianSigmaVoxels);
  derive(params.graph.quadratic_threshold, kQuadraticThresholdVoxels);
  derive(params.evaluation.inlier_threshold, kInlierThresholdVoxels);
  return params;
}

namespace {

// Front end (given as a callable that may throw) then the core; every failure becomes a failed result.
template <typename FrontEnd>
CloudRegistrationResult registerWith(FrontEnd front_end, const FeatureParams& feature_params,
                                     const MacParams& mac_params, const StopFlag* stop) {
  CloudRegistrationResult result;
  MacResult& registration = result.registration;
  const auto fail = [&](RegistrationStatus status, const std::string& message) {
    registration.success = false;
    registration.status = status;
    registration.message = message;
    return result;
  };
  const auto problems = validateFeatureParams(feature_params);
  if (!problems.empty()) {
    std::string message = "invalid feature parameters:";
    for (const auto& p : problems) message += " " + p;
    return fail(RegistrationStatus::kInvalidParameters, message);
  }
  try {
    result.features = front_end();
  } catch (const Cancelled& e) {
    return fail(RegistrationStatus::kCancelled, e.what());
  } catch (const std::invalid_argument& e) {
    return fail(RegistrationStatus::kInvalidInput, e.what());
  } catch (const std::exception& e) {
    return fail(RegistrationStatus::kInternalError, std::string("front end failed: ") + e.what());
  }
  if (stopRequested(stop)) return fail(RegistrationStatus::kCancelled, "cancelled after the front end");
  const MacParams params = inCloudUnits(mac_params, feature_params, result.features.stats);
  // The clouds are the core's witness: their evidence joins the correspondences' before its one decision.
  const AlignmentJudge clouds(result.features, params.evaluation.inlier_threshold, params.num_threads);
  registration = registerCorrespondences(result.features.correspondences, params, stop, &clouds);
  return result;
}

}  // namespace

CloudRegistrationResult registerClouds(const PointCloud& source, const PointCloud& target,
                                       const FeatureParams& feature_params, const MacParams& mac_params,
                                       const StopFlag* stop) {
  return registerWith([&] { return computeCorrespondences(source, target, feature_params, stop); },
                      feature_params, mac_params, stop);
}

CloudRegistrationResult registerCloudToDescribed(const PointCloud& source, const DescribedCloud& target,
                                                 const FeatureParams& feature_params,
                                                 const MacParams& mac_params, const StopFlag* stop) {
  // An auto voxel size and the support scale follow the target, described before the source was known.
  const FeatureParams params = withVoxel(feature_params, target.params.voxel_size);
  return registerWith(
      [&] {
        return matchDescribedClouds(describeCloud(source, params, "source", stop, target.support_scale),
                                    target, params, stop);
      },
      params, mac_params, stop);
}

CloudRegistrationResult registerDescribedClouds(const DescribedCloud& source, const DescribedCloud& target,
                                                const FeatureParams& feature_params,
                                                const MacParams& mac_params, const StopFlag* stop) {
  const FeatureParams params = withVoxel(feature_params, target.params.voxel_size);
  return registerWith([&] { return matchDescribedClouds(source, target, params, stop); }, params, mac_params,
                      stop);
}

std::vector<CloudRegistrationResult> registerCandidates(const PointCloud& source,
                                                        const std::vector<PointCloud::ConstPtr>& targets,
                                                        const FeatureParams& feature_params,
                                                        const MacParams& mac_params, const StopFlag* stop) {
  FeatureParams params = feature_params;
  DescribedCloud described;
  std::exception_ptr source_error;
  // Invalid parameters are each result's kInvalidParameters (registerWith), not a failed description.
  if (validateFeatureParams(feature_params).empty()) {
    try {
      if (params.voxel_size == 0.0) {
        double voxel = autoVoxelSize(source, stop);
        for (const auto& target : targets) {
          if (target) voxel = std::max(voxel, autoVoxelSize(*target, stop));
        }
        params = withVoxel(feature_params, voxel);
      }
      described = describeCloud(source, params, "source", stop);
    } catch (...) {
      source_error = std::current_exception();
    }
  }
  std::vector<CloudRegistrationResult> results;
  for (std::size_t k = 0; k < targets.size(); ++k) {
    results.push_back(registerWith(
        [&]() -> FeatureCorrespondences {
          if (source_error) std::rethrow_exception(source_error);
          if (!targets[k]) throw std::invalid_argument("candidate " + std::to_string(k) + " has no cloud");
          DescribedCloud target = describeCloud(*targets[k], params, "target", stop);
          if (target.support_scale == described.support_scale)
            return matchDescribedClouds(described, target, params, stop);
          // A sparser candidate than the source (or a denser one) is matched as a pair would be.
          DescribedCloud source_at = described;
          atCommonScale(source_at, source, target, *targets[k], stop);
          return matchDescribedClouds(source_at, target, params, stop);
        },
        params, mac_params, stop));
    described.times = StageTimes();  // described once: counted in the first result
  }
  return results;
}

CandidateRank rankOf(const MacResult& result) {
  return {result.success, result.confidence, result.counters.inliers};
}

std::vector<std::size_t> bestFirst(const std::vector<CandidateRank>& ranks) {
  std::vector<std::size_t> order(ranks.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const CandidateRank &ra = ranks[a], &rb = ranks[b];
    if (ra.success != rb.success) return ra.success;
    return ra.success ? ra.confidence > rb.confidence : ra.inliers > rb.inliers;
  });
  return order;
}

}  // namespace mac_registration
