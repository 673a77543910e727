#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace mac_registration {

// Localizing a query cloud in a map described once (features/map_relocalization.hpp). The map is cut into
// candidate places on a grid in its x-y plane (REP-103: z up); a query's descriptors vote for the places
// their nearest map descriptors lie in, and MAC and the verification run on the best-ranked places.
struct RelocalizationParams {
  // [m], >= 0: spacing of the candidate places' grid. 0 = auto: kPlaceSpacingVoxels x features.voxel_size.
  double place_spacing = 0.0;
  // [count], in [1, 20]: places MAC and the verification run on, best-ranked first.
  std::size_t max_candidates = 3;
  // [s], > 0: wall time of a query after its description; no further place is started beyond it (the
  // best-ranked one always runs).
  double time_limit = 2.0;
};

// The auto place spacing in voxel sizes: 5 m at a lidar map's 0.5 m voxels, a fifth to a tenth of a
// lidar query's reach, so that some place centre lies within 3.5 m of any query.
constexpr double kPlaceSpacingVoxels = 10.0;

// Every problem with the parameters as a sentence naming parameter, value and allowed range; empty if usable.
std::vector<std::string> validateRelocalizationParams(const RelocalizationParams& params);

}  // namespace mac_registration
