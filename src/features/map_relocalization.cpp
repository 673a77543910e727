#include "mac_registration/features/map_relocalization.hpp"

#include <omp.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "mac_registration/features/feature_matching.hpp"

namespace mac_registration {

namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The share of a query's keypoints (by distance from their centroid, in the x-y plane) its reach is
// taken from: the farthest few are stray returns, not the extent of what it saw.
constexpr double kReachQuantile = 0.9;

// Two confirmed places whose poses move the query's points less than this many inlier thresholds (RMS)
// apart found the same pose (neighbouring places overlap).
constexpr double kSamePoseFactor = 5.0;

// Places ranked and reported beyond those registered: what a caller sees of the runners-up.
constexpr std::size_t kReportedPlaces = 10;

// Places registered a query at which the verification's min_confidence was measured as the bar for a
// location: the preset's three, with no wrong location in any NCLT run. Each further place registered is
// another chance for a look-alike to verify (at ten places a single scan was placed 98 m off at confidence
// 0.58), so beyond them the odds a location needs grow with the places registered.
constexpr std::size_t kCalibratedPlaces = 3;

// Query descriptors that vote (every k-th): the votes' search is the largest part of a query on a large map,
// so its cost is bounded by their number. On NCLT windows of ~15 000 keypoints, 3000 voters localized 115
// windows against all voters' 116, at 0.62 s a query instead of 1.59 (doc/decisions/map-relocalization.md).
constexpr std::size_t kVoters = 3000;

// A vote goes to a map descriptor within (1 + this) of the nearest one's distance, found in a kd-tree
// instead of by scanning every map descriptor: a vote only shortlists places, which the rigidity of the
// votes and the registration then rank. On a map of 1.7 M keypoints the search took a third of the exact
// scan's time, and the same windows were localized (doc/decisions/map-relocalization.md).
constexpr double kVoteEpsilon = 1.0;

// Places the votes shortlist for the rigidity score: the votes alone put the true place anywhere in the
// first ten; scoring twenty costs little beside the votes' search.
constexpr std::size_t kShortlist = 20;

double resolvedSpacing(const RelocalizationParams& params, double voxel_size) {
  return params.place_spacing > 0.0 ? params.place_spacing : kPlaceSpacingVoxels * voxel_size;
}

// The points' mean in double: the local origin of a map in large coordinates.
Eigen::Vector3d finiteMean(const PointCloud& cloud) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (const auto& p : cloud) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    sum += Eigen::Vector3d(p.x, p.y, p.z);
    ++n;
  }
  return n > 0 ? Eigen::Vector3d(sum / double(n)) : Eigen::Vector3d::Zero();
}

// The subset of the map's description at `indices`, moved by -`offset`: a place as registerDescribedClouds
// takes a target, in coordinates of its own. The fine alignment linearizes its rotation about the target
// frame's origin: a place kilometres from the map's mean would leave its normal equations ill-conditioned
// (on a 5 x 2 km map, a right pose's position came out 4.6 m uncertain instead of 1 cm).
DescribedCloud placeCloud(const DescribedCloud& map, const std::vector<int>& indices,
                          const Eigen::Vector3f& offset) {
  DescribedCloud place;
  place.params = map.params;
  place.support_scale = map.support_scale;
  place.keypoints.reset(new PointCloud);
  place.normals.reset(new pcl::PointCloud<pcl::Normal>);
  place.descriptors.reset(new pcl::PointCloud<pcl::FPFHSignature33>);
  place.keypoints->reserve(indices.size());
  place.normals->reserve(indices.size());
  place.descriptors->reserve(indices.size());
  for (const int i : indices) {
    pcl::PointXYZ p = (*map.keypoints)[i];
    p.getVector3fMap() -= offset;
    place.keypoints->push_back(p);
    place.normals->push_back((*map.normals)[i]);
    place.descriptors->push_back((*map.descriptors)[i]);
  }
  place.descriptor_index = std::make_shared<const DescriptorIndex>(place.descriptors);
  place.points = place.voxels = indices.size();
  // No single place saw a map: the verification takes no free-space evidence from its side.
  place.viewpoint = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  return place;
}

// Sums of a row-major grid over squares, from its summed-area table.
class SquareSums {
 public:
  SquareSums(const std::vector<double>& values, int columns, int rows)
      : columns_(columns), rows_(rows), table_(std::size_t(columns + 1) * (rows + 1), 0.0) {
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < columns; ++c) {
        at(c + 1, r + 1) = values[std::size_t(r) * columns + c] + at(c, r + 1) + at(c + 1, r) - at(c, r);
      }
    }
  }
  // The sum over the cells within `half` cells of (column, row), clipped to the grid.
  double around(int column, int row, int half) const {
    const int c0 = std::max(0, column - half), c1 = std::min(columns_, column + half + 1);
    const int r0 = std::max(0, row - half), r1 = std::min(rows_, row + half + 1);
    return value(c1, r1) - value(c0, r1) - value(c1, r0) + value(c0, r0);
  }

 private:
  double& at(int c, int r) { return table_[std::size_t(r) * (columns_ + 1) + c]; }
  double value(int c, int r) const { return table_[std::size_t(r) * (columns_ + 1) + c]; }
  int columns_, rows_;
  std::vector<double> table_;
};

// How far the query reaches from its centroid in the x-y plane [m].
double queryReach(const PointCloud& keypoints) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : keypoints) mean += Eigen::Vector2d(p.x, p.y);
  mean /= double(std::max<std::size_t>(1, keypoints.size()));
  std::vector<double> distances;
  distances.reserve(keypoints.size());
  for (const auto& p : keypoints) distances.push_back((Eigen::Vector2d(p.x, p.y) - mean).norm());
  if (distances.empty()) return 0.0;
  const auto k = std::size_t(kReachQuantile * double(distances.size() - 1));
  std::nth_element(distances.begin(), distances.begin() + k, distances.end());
  return distances[k];
}

struct RankedPlace {
  int column = 0, row = 0;
  double score = 0.0;  // the vote excess, then the rigidity score
  double votes = 0.0;
};

bool insideArea(const DescribedMap& map, int column, int row, const SearchArea* area) {
  if (!area) return true;
  const Eigen::Vector2d centre =
      map.origin.head<2>() + map.low + map.cell_size * Eigen::Vector2d(column + 0.5, row + 0.5);
  return (centre - area->centre).norm() <= area->radius;
}

// Places (within `area`, when given) scored by the votes within the query's reach beyond the share of the
// map's keypoints there, best first, each at least the reach from every better one.
std::vector<RankedPlace> rankPlaces(const DescribedMap& map, const std::vector<double>& votes, double reach,
                                    std::size_t wanted, const SearchArea* area) {
  std::vector<double> keypoints(map.cell_keypoints.size());
  for (std::size_t i = 0; i < keypoints.size(); ++i) keypoints[i] = double(map.cell_keypoints[i].size());
  const SquareSums vote_sums(votes, map.columns, map.rows), keypoint_sums(keypoints, map.columns, map.rows);
  const double total_votes = std::accumulate(votes.begin(), votes.end(), 0.0);
  const double total_keypoints = double(map.cloud.keypoints->size());
  const int half = std::max(1, int(std::ceil(reach / map.cell_size - 0.5)));
  std::vector<RankedPlace> all;
  for (int r = 0; r < map.rows; ++r) {
    for (int c = 0; c < map.columns; ++c) {
      if (map.cell_keypoints[std::size_t(r) * map.columns + c].empty() || !insideArea(map, c, r, area))
        continue;
      RankedPlace place;
      place.column = c;
      place.row = r;
      place.votes = vote_sums.around(c, r, half);
      place.score = place.votes - total_votes * keypoint_sums.around(c, r, half) / total_keypoints;
      all.push_back(place);
    }
  }
  std::sort(all.begin(), all.end(), [](const RankedPlace& a, const RankedPlace& b) {
    return a.score != b.score ? a.score > b.score : (a.row != b.row ? a.row < b.row : a.column < b.column);
  });
  std::vector<RankedPlace> kept;
  const double apart = reach / map.cell_size;
  for (const auto& place : all) {
    if (kept.size() >= wanted) break;
    const bool separate = std::all_of(kept.begin(), kept.end(), [&](const RankedPlace& other) {
      return std::hypot(place.column - other.column, place.row - other.row) >= apart;
    });
    if (separate) kept.push_back(place);
  }
  return kept;
}

// One voter's match: a query keypoint and the map keypoint of its nearest descriptor.
struct Vote {
  Eigen::Vector3f query, map;
};

// Rescores each place by the pairs of its votes (those whose map keypoint lies within `reach` of it) whose
// lengths agree within `tau`, as a rigid motion keeps them: chance matches scatter, the right place's agree
// with each other. Best first.
void rescoreByRigidity(const DescribedMap& map, const std::vector<Vote>& votes, double reach, double tau,
                       std::vector<RankedPlace>& places) {
  const float agree = float(tau), shortest = float(2.0 * tau);
  for (auto& place : places) {
    const Eigen::Vector2d centre =
        map.low + map.cell_size * Eigen::Vector2d(place.column + 0.5, place.row + 0.5);
    std::vector<const Vote*> inside;
    for (const Vote& v : votes) {
      if ((v.map.head<2>().cast<double>() - centre).norm() <= reach) inside.push_back(&v);
    }
    std::size_t agreeing = 0;
    for (std::size_t i = 0; i < inside.size(); ++i) {
      for (std::size_t j = i + 1; j < inside.size(); ++j) {
        const float length = (inside[i]->query - inside[j]->query).norm();
        // Pairs closer than two tau agree by their nearness alone.
        if (length < shortest) continue;
        agreeing += std::abs(length - (inside[i]->map - inside[j]->map).norm()) < agree;
      }
    }
    place.score = double(agreeing);
  }
  std::stable_sort(places.begin(), places.end(),
                   [](const RankedPlace& a, const RankedPlace& b) { return a.score > b.score; });
}

// Why the fine alignment leaves `result`'s pose unconstrained, or "" when it pins it down: within `tau` [m]
// along each axis and within tau / `reach` [rad] about each (a turn that moves the query's far points by
// tau).
std::string unconstrainedReason(const MacResult& result, double tau, double reach) {
  const FineAlignment& fine = result.fine_alignment;
  if (!fine.ran) return "no fine alignment on the map";
  const Eigen::Matrix<double, 6, 1> deviation = fine.covariance.diagonal().cwiseSqrt();
  const double translation = deviation.head<3>().maxCoeff(), rotation = deviation.tail<3>().maxCoeff();
  std::ostringstream text;
  if (translation > tau)
    text << "the fit leaves its position unconstrained (standard deviation " << translation << " m > tau "
         << tau << " m)";
  else if (rotation > tau / std::max(reach, tau))
    text << "the fit leaves its heading unconstrained (standard deviation " << rotation * 180.0 / M_PI
         << " deg)";
  return text.str();
}

// The map keypoints within `radius` of the centre of cell (column, row) in the x-y plane.
std::vector<int> keypointsAround(const DescribedMap& map, int column, int row, double radius) {
  const Eigen::Vector2d centre = map.low + map.cell_size * Eigen::Vector2d(column + 0.5, row + 0.5);
  const int half = int(std::ceil(radius / map.cell_size));
  std::vector<int> indices;
  for (int r = std::max(0, row - half); r <= std::min(map.rows - 1, row + half); ++r) {
    for (int c = std::max(0, column - half); c <= std::min(map.columns - 1, column + half); ++c) {
      for (const int i : map.cell_keypoints[std::size_t(r) * map.columns + c]) {
        const auto& p = (*map.cloud.keypoints)[i];
        if ((Eigen::Vector2d(p.x, p.y) - centre).norm() <= radius) indices.push_back(i);
      }
    }
  }
  return indices;
}

// RMS distance between the query's keypoints placed by two poses.
double poseDistance(const PointCloud& keypoints, const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  double sum = 0.0;
  for (const auto& p : keypoints) {
    const Eigen::Vector3d x = p.getVector3fMap().cast<double>();
    sum += (a * x - b * x).squaredNorm();
  }
  return std::sqrt(sum / double(std::max<std::size_t>(1, keypoints.size())));
}

// Every k-th query descriptor (kVoters at most) and the map keypoint of its nearest map descriptor, and the
// votes per place cell. Throws Cancelled when `stop` is raised.
std::vector<Vote> castVotes(const DescribedCloud& query, const DescribedMap& map, int threads,
                            std::vector<double>& cell_votes, const StopFlag* stop) {
  FpfhCloud voters;
  std::vector<Vote> votes;
  const std::size_t stride = (query.descriptors->size() + kVoters - 1) / kVoters;
  for (std::size_t i = 0; i < query.descriptors->size(); i += stride) {
    voters.push_back((*query.descriptors)[i]);
    votes.push_back({(*query.keypoints)[i].getVector3fMap(), Eigen::Vector3f::Zero()});
  }
  const std::vector<NearestDescriptors> nearest =
      nearestDescriptorsKdTree(voters, nullptr, *map.cloud.descriptor_index, 1, kVoteEpsilon, threads, stop);
  cell_votes.assign(map.cell_keypoints.size(), 0.0);
  for (std::size_t v = 0; v < nearest.size(); ++v) {
    const auto& p = (*map.cloud.keypoints)[nearest[v].nearest];
    votes[v].map = p.getVector3fMap();
    const int c = std::min(map.columns - 1, int((p.x - map.low.x()) / map.cell_size));
    const int r = std::min(map.rows - 1, int((p.y - map.low.y()) / map.cell_size));
    cell_votes[std::size_t(r) * map.columns + c] += 1.0;
  }
  return votes;
}

// A ranked place as reported, registered against the query when `run`: the map keypoints within
// `radius` of its centre, moved to that centre (placeCloud).
PlaceCandidate placeCandidate(const DescribedMap& map, const RankedPlace& place, double radius,
                              const DescribedCloud& query, const FeatureParams& features,
                              const MacParams& mac, bool run, const StopFlag* stop) {
  PlaceCandidate candidate;
  const Eigen::Vector2d centre =
      map.low + map.cell_size * Eigen::Vector2d(place.column + 0.5, place.row + 0.5);
  const std::vector<int> indices = keypointsAround(map, place.column, place.row, radius);
  double z = 0.0;
  for (const int i : indices) z += (*map.cloud.keypoints)[i].z;
  candidate.centre =
      map.origin + Eigen::Vector3d(centre.x(), centre.y(), indices.empty() ? 0.0 : z / indices.size());
  candidate.score = place.score;
  candidate.votes = std::size_t(place.votes);
  candidate.keypoints = indices.size();
  if (!run || indices.size() < 3) return candidate;
  const Eigen::Vector3f offset(float(centre.x()), float(centre.y()), 0.0f);
  candidate.registration =
      registerDescribedClouds(query, placeCloud(map.cloud, indices, offset), features, mac, stop);
  candidate.registered = true;
  candidate.T_map_query = Eigen::Translation3d(map.origin + offset.cast<double>()) *
                          candidate.registration.registration.T_target_source;
  return candidate;
}

// The answer from the registered places of `out`: the confirmed one of highest confidence, unless another
// confirmed a pose more than kSamePoseFactor tau (RMS over the query's keypoints) from it. Sets chosen,
// T_map_query, confidence and each candidate's `unconstrained`; returns the outcome and its message.
std::pair<RelocalizationOutcome, std::string> decide(RelocalizationResult& out, const PointCloud& query,
                                                     double tau, double min_confidence) {
  const std::size_t registered = std::size_t(std::count_if(
      out.candidates.begin(), out.candidates.end(), [](const PlaceCandidate& c) { return c.registered; }));
  const double bar = locationConfidenceBar(min_confidence, registered);
  std::vector<int> confirmed;
  for (int k = 0; k < int(out.candidates.size()); ++k) {
    PlaceCandidate& c = out.candidates[k];
    if (!c.registered || !c.registration.registration.success) continue;
    c.unconstrained = unconstrainedReason(c.registration.registration, tau, out.query_radius);
    if (c.unconstrained.empty() && c.registration.registration.confidence < bar) {
      std::ostringstream text;
      text << std::fixed << std::setprecision(2) << "its confidence "
           << c.registration.registration.confidence << " is below the " << bar << " that " << registered
           << " places registered call for";
      c.unconstrained = text.str();
    }
    if (c.unconstrained.empty()) confirmed.push_back(k);
  }
  const auto confidence = [&](int k) { return out.candidates[k].registration.registration.confidence; };
  std::stable_sort(confirmed.begin(), confirmed.end(),
                   [&](int a, int b) { return confidence(a) > confidence(b); });
  int best = confirmed.empty() ? -1 : confirmed.front();
  if (best < 0) {
    for (int k = 0; k < int(out.candidates.size()); ++k) {
      if (out.candidates[k].registered && (best < 0 || confidence(k) > confidence(best))) best = k;
    }
  }
  out.chosen = best;
  if (best >= 0) {
    out.T_map_query = out.candidates[best].T_map_query;
    out.confidence = confidence(best);
  }
  std::ostringstream text;
  if (confirmed.empty()) {
    text << "no place confirmed a pose";
    if (best >= 0)
      text << " (best: place " << best << ", "
           << (out.candidates[best].unconstrained.empty()
                   ? out.candidates[best].registration.registration.message
                   : "verified, but " + out.candidates[best].unconstrained)
           << ")";
    return {RelocalizationOutcome::kNotLocalized, text.str()};
  }
  for (std::size_t i = 1; i < confirmed.size(); ++i) {
    const double apart = poseDistance(query, out.candidates[confirmed[i]].T_map_query, out.T_map_query);
    if (apart > kSamePoseFactor * tau) {
      text << "places " << best << " and " << confirmed[i] << " confirmed poses " << apart
           << " m apart (RMS over the query): ambiguous";
      return {RelocalizationOutcome::kAmbiguous, text.str()};
    }
  }
  return {RelocalizationOutcome::kLocalized, ""};
}

}  // namespace

double locationConfidenceBar(double min_confidence, std::size_t places_registered) {
  if (places_registered <= kCalibratedPlaces || !(min_confidence > 0.0) || !(min_confidence < 1.0))
    return min_confidence;
  const double odds = min_confidence / (1.0 - min_confidence) * double(places_registered) / kCalibratedPlaces;
  return odds / (1.0 + odds);
}

std::size_t DescribedMap::bytes() const {
  const std::size_t n = cloud.keypoints ? cloud.keypoints->size() : 0;
  std::size_t grid = cell_keypoints.size() * sizeof(std::vector<int>) + n * sizeof(int);
  // The descriptors once in the cloud and once in the votes' kd-tree (FLANN's copy; its nodes not counted).
  return n * (sizeof(pcl::PointXYZ) + sizeof(pcl::Normal) + 2 * sizeof(pcl::FPFHSignature33)) + grid;
}

DescribedMap describeMap(const PointCloud& map, const FeatureParams& features,
                         const RelocalizationParams& params, const StopFlag* stop,
                         const Eigen::Vector3d& map_origin) {
  const auto start = Clock::now();
  if (features.voxel_size <= 0.0)
    throw std::invalid_argument("a map is described with a given features.voxel_size, not auto");
  const auto problems = validateRelocalizationParams(params);
  if (!problems.empty()) throw std::invalid_argument(problems.front());
  DescribedMap out;
  out.origin = finiteMean(map);
  PointCloud local;
  local.reserve(map.size());
  for (const auto& p : map) {
    pcl::PointXYZ q;
    q.getVector3fMap() = (p.getVector3fMap().cast<double>() - out.origin).cast<float>();
    local.push_back(q);
  }
  out.cloud = describeCloud(local, features, "map", stop);
  out.cloud.points = map.size();
  throwIfStopped(stop, "indexing the map");
  // The votes' kd-tree, built now rather than by the first query.
  out.cloud.descriptor_index->tree();
  out.origin += map_origin;

  out.cell_size = resolvedSpacing(params, features.voxel_size);
  Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d high = -low;
  for (const auto& p : *out.cloud.keypoints) {
    low = low.cwiseMin(Eigen::Vector2d(p.x, p.y));
    high = high.cwiseMax(Eigen::Vector2d(p.x, p.y));
  }
  if (out.cloud.keypoints->empty()) low = high = Eigen::Vector2d::Zero();
  out.low = low;
  out.columns = int(std::floor((high.x() - low.x()) / out.cell_size)) + 1;
  out.rows = int(std::floor((high.y() - low.y()) / out.cell_size)) + 1;
  out.cell_keypoints.assign(std::size_t(out.columns) * out.rows, {});
  for (int i = 0; i < int(out.cloud.keypoints->size()); ++i) {
    const auto& p = (*out.cloud.keypoints)[i];
    const int c = std::min(out.columns - 1, int((p.x - low.x()) / out.cell_size));
    const int r = std::min(out.rows - 1, int((p.y - low.y()) / out.cell_size));
    out.cell_keypoints[std::size_t(r) * out.columns + c].push_back(i);
  }
  out.describe_ms = millisecondsSince(start);
  return out;
}

const char* toString(RelocalizationOutcome outcome) {
  switch (outcome) {
    case RelocalizationOutcome::kLocalized:
      return "localized";
    case RelocalizationOutcome::kNotLocalized:
      return "not localized";
    case RelocalizationOutcome::kAmbiguous:
      return "ambiguous";
    case RelocalizationOutcome::kInvalidInput:
      return "invalid input";
    case RelocalizationOutcome::kCancelled:
      return "cancelled";
  }
  return "?";
}

RelocalizationResult relocalize(const DescribedMap& map, const PointCloud& query, const FeatureParams& given,
                                const MacParams& mac, const RelocalizationParams& params,
                                const StopFlag* stop, const SearchArea* area) {
  const auto start = Clock::now();
  RelocalizationResult out;
  const auto finish = [&](RelocalizationOutcome outcome, const std::string& message) {
    out.outcome = outcome;
    out.success = outcome == RelocalizationOutcome::kLocalized;
    out.message = message;
    out.total_ms = millisecondsSince(start);
    return out;
  };
  FeatureParams features = given;
  if (features.voxel_size == 0.0) features.voxel_size = map.cloud.params.voxel_size;
  std::vector<std::string> problems = validateRelocalizationParams(params);
  for (auto& p : validateFeatureParams(features)) problems.push_back(std::move(p));
  if (area && !(area->centre.allFinite() && area->radius > 0.0))
    problems.push_back("the search area needs a finite centre and a radius > 0 [m]");
  if (!problems.empty()) return finish(RelocalizationOutcome::kInvalidInput, problems.front());
  if (!map.cloud.keypoints || map.cloud.keypoints->empty())
    return finish(RelocalizationOutcome::kInvalidInput, "the map has no keypoints");
  if (!describedWith(map.cloud, features) || features.voxel_size != map.cloud.params.voxel_size)
    return finish(RelocalizationOutcome::kInvalidInput,
                  "the map was described with other voxel_size, radius or support factors than these");

  DescribedCloud described;
  try {
    described = describeCloud(query, features, "query", stop, map.cloud.support_scale);
  } catch (const Cancelled& e) {
    return finish(RelocalizationOutcome::kCancelled, e.what());
  } catch (const std::exception& e) {
    return finish(RelocalizationOutcome::kInvalidInput, e.what());
  }
  out.describe_ms = millisecondsSince(start);
  out.query_keypoints = described.keypoints->size();
  if (described.keypoints->size() < 3)
    return finish(RelocalizationOutcome::kInvalidInput, "the query has fewer than 3 described keypoints");

  // Each voter (a query descriptor) votes for the cell of its nearest map descriptor; the vote excess
  // shortlists places, and the rigidity of their votes ranks them.
  const auto ranking_start = Clock::now();
  std::vector<Vote> votes;
  std::vector<double> cell_votes;
  try {
    const int threads = features.num_threads > 0 ? features.num_threads : omp_get_max_threads();
    votes = castVotes(described, map, threads, cell_votes, stop);
  } catch (const Cancelled& e) {
    return finish(RelocalizationOutcome::kCancelled, e.what());
  }
  out.query_radius = queryReach(*described.keypoints);
  std::vector<RankedPlace> ranked = rankPlaces(map, cell_votes, out.query_radius, kShortlist, area);
  if (ranked.empty() && area)
    return finish(RelocalizationOutcome::kNotLocalized, "no place of the map lies within the search area");
  const double tau = mac.evaluation.inlier_threshold > 0.0 ? mac.evaluation.inlier_threshold
                                                           : kInlierThresholdVoxels * features.voxel_size;
  rescoreByRigidity(map, votes, out.query_radius, tau, ranked);
  ranked.resize(std::min(ranked.size(), std::max(params.max_candidates, kReportedPlaces)));
  out.ranking_ms = millisecondsSince(ranking_start);

  const auto registration_start = Clock::now();
  for (std::size_t k = 0; k < ranked.size(); ++k) {
    const bool in_time = k == 0 || millisecondsSince(registration_start) < 1e3 * params.time_limit;
    const bool run = k < params.max_candidates && in_time && !stopRequested(stop);
    out.candidates.push_back(placeCandidate(map, ranked[k], out.query_radius + map.cell_size, described,
                                            features, mac, run, stop));
  }
  out.registration_ms = millisecondsSince(registration_start);
  if (stopRequested(stop))
    return finish(RelocalizationOutcome::kCancelled, "cancelled registering the places");
  const auto [outcome, message] = decide(out, *described.keypoints, tau, mac.verification.min_confidence);
  return finish(outcome, message);
}

}  // namespace mac_registration
