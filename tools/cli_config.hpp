#pragma once

#include <string>

#include "mac_registration/core/parameters.hpp"

namespace mac_registration {

// Sets one parameter from text, key as in the YAML presets ("graph.t_cmp", "evaluation.metric", ...).
// Throws std::invalid_argument naming the key for unknown keys and unparsable values.
void setParam(MacParams& params, const std::string& key, const std::string& value);

// Reads a two-level YAML preset (section: / indented key: value; '#' comments) into params. Sections other
// than the core's (e.g. a ROS node's) are skipped. Throws std::runtime_error with file and line.
void loadParamsFile(MacParams& params, const std::string& path);

}  // namespace mac_registration
