#pragma once

#include <functional>
#include <string>

#include "mac_registration/core/parameters.hpp"
#include "mac_registration/features/feature_params.hpp"

namespace mac_registration {

// Sets one parameter from text, key as in the YAML presets ("graph.t_cmp", "evaluation.metric", ...).
// Throws std::invalid_argument naming the key for unknown keys and unparsable values.
void setParam(MacParams& params, const std::string& key, const std::string& value);

// Reads a two-level YAML preset (section: / indented key: value; '#' comments) into params. Sections other
// than the core's (e.g. features:, a ROS node's) are skipped. Throws std::runtime_error with file and line.
void loadParamsFile(MacParams& params, const std::string& path);

// The same for the front end's keys, "features.voxel_size" etc. (FeatureParams has no PCL type, so this
// works in a core-only build too; validateFeatureParams() of the features library checks ranges).
bool isFeatureKey(const std::string& key);
void setFeatureParam(FeatureParams& params, const std::string& key, const std::string& value);
// Reads only the features: section of a preset; other sections are skipped.
void loadFeatureParamsFile(FeatureParams& params, const std::string& path);

// One "--set KEY=VALUE" of a tool: a features.* key goes to `features`, any other to `params`.
void applyAssignment(MacParams& params, FeatureParams& features, const std::string& assignment);

// Calls visit("section.key" or "key", value) for every value of a preset, in file order. Exceptions of
// visit come back as std::runtime_error prefixed with "file:line: ". The one YAML reader of the tools.
void readPresetFile(const std::string& path,
                    const std::function<void(const std::string& key, const std::string& value)>& visit);

}  // namespace mac_registration
