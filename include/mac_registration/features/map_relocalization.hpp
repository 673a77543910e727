#pragma once

// Localizing a cloud in a map described once: the map's keypoints and descriptors are computed when it is
// loaded, and each query only describes itself, ranks the map's places by how many of its descriptors find
// their nearest map descriptor there, and runs MAC and the verification on the best-ranked places. A pose
// no place's verification confirms is not a result, and two places confirmed at different poses are an
// ambiguous answer, not a guess. A location is also a pose the fine alignment on the map constrains: a
// standard deviation above the inlier threshold tau along any axis, or above tau / the query's reach
// (radians) about one, leaves the robot's position unknown in that direction.

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

#include "mac_registration/config/relocalization_params.hpp"
#include "mac_registration/features/cloud_registration.hpp"

namespace mac_registration {

// A map as the search needs it, built by describeMap() and only read by queries: any number of queries may
// use one at the same time.
struct DescribedMap {
  // The map's keypoints, normals and descriptors in the local frame: the map's coordinates minus `origin`,
  // so that a map in large coordinates (UTM) keeps the float precision of its keypoints.
  DescribedCloud cloud;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // [m] the local frame's origin in the map frame
  // The places' grid in the local x-y plane: cell (column, row) spans [low + cell_size * (column, row),
  // low + cell_size * (column + 1, row + 1)).
  double cell_size = 0.0;  // [m] relocalization.place_spacing resolved
  Eigen::Vector2d low = Eigen::Vector2d::Zero();
  int columns = 0, rows = 0;
  std::vector<std::vector<int>> cell_keypoints;  // row-major: the keypoints (of `cloud`) in each cell
  double describe_ms = 0.0;                      // describing and indexing it, wall time
  // An estimate of what the description holds [bytes]: keypoints, normals, descriptors, their search
  // structure and the grid.
  std::size_t bytes() const;
};

// Describes `map` (any frame whose z axis is up; may hold NaNs) with `features` (an auto voxel size is
// refused: a map's keypoint spacing must not follow its extent) and builds the places' grid. `map_origin`:
// where `map`'s own origin lies in the map frame, for a map read in global coordinates and shifted
// (loadLocalCloud's origin); every pose and centre of the answers is in the map frame. Throws
// std::invalid_argument for invalid parameters or a map with fewer than 3 finite points, Cancelled when
// `stop` is raised before it is done.
DescribedMap describeMap(const PointCloud& map, const FeatureParams& features,
                         const RelocalizationParams& params, const StopFlag* stop = nullptr,
                         const Eigen::Vector3d& map_origin = Eigen::Vector3d::Zero());

// One place of the map, as ranked for a query.
struct PlaceCandidate {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // [m] in the map frame (z: the map's mean there)
  // Pairs of the place's votes whose lengths agree as a rigid motion keeps them (its rank).
  double score = 0.0;
  std::size_t votes = 0;      // query descriptors whose nearest map descriptor lies within the place
  std::size_t keypoints = 0;  // map keypoints registered against (the place and its margin)
  bool registered = false;    // MAC and the verification ran on it (within max_candidates and time)
  // Why its verified pose does not count as a location, when it does not: the fine alignment on the map
  // did not run or leaves the pose unconstrained beyond the inlier threshold in some direction, or its
  // confidence is below locationConfidenceBar for the places registered.
  std::string unconstrained;
  CloudRegistrationResult registration;  // when registered: query (source) against the place (target)
  Eigen::Isometry3d T_map_query = Eigen::Isometry3d::Identity();  // when registered, in the map frame
};

enum class RelocalizationOutcome {
  kLocalized,     // one place confirmed the pose
  kNotLocalized,  // no place confirmed a pose (or no place was ranked)
  kAmbiguous,     // places at different poses confirmed theirs: none is reported as the answer
  kInvalidInput,  // unusable query or parameters
  kCancelled,
};

const char* toString(RelocalizationOutcome outcome);

struct RelocalizationResult {
  RelocalizationOutcome outcome = RelocalizationOutcome::kNotLocalized;
  bool success = false;  // outcome == kLocalized
  std::string message;   // why not, when not
  // The pose of the query in the map frame (maps query points into the map): the confirmed place's, or
  // without one the best-ranked registered place's best estimate, marked by success = false.
  Eigen::Isometry3d T_map_query = Eigen::Isometry3d::Identity();
  double confidence = 0.0;
  int chosen = -1;                         // the candidate T_map_query comes from, -1 = none registered
  std::vector<PlaceCandidate> candidates;  // best-ranked first
  double query_radius = 0.0;               // [m] the query's reach the places were scored over
  std::size_t query_keypoints = 0;
  // [ms] wall times: describing the query, ranking the places, registering them, all of it.
  double describe_ms = 0.0, ranking_ms = 0.0, registration_ms = 0.0, total_ms = 0.0;
};

// Where the query is known to be, like a pose estimate clicked in rviz: only the places whose centre lies
// within `radius` of `centre` (x-y, the map frame) are ranked and registered.
struct SearchArea {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // [m]
  double radius = 0.0;                               // [m]
};

// The confidence a verified place needs to count as the location when `places_registered` places were
// registered for one query: verification.min_confidence up to three places (where it was measured), and
// beyond them the confidence whose odds are min_confidence's times places_registered / 3: each place
// registered is one more chance for a look-alike to verify.
double locationConfidenceBar(double min_confidence, std::size_t places_registered);

// Localizes `query` (its own frame, e.g. the sensor's) in `map`, in `area` when given. `features` must
// describe as the map was described (voxel size, radii); its matching parameters apply to each place.
// Never throws.
RelocalizationResult relocalize(const DescribedMap& map, const PointCloud& query,
                                const FeatureParams& features, const MacParams& mac,
                                const RelocalizationParams& params, const StopFlag* stop = nullptr,
                                const SearchArea* area = nullptr);

}  // namespace mac_registration
