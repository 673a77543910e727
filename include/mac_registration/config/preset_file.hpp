#pragma once

#include <functional>
#include <string>

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {

// Calls visit("section.key" or "key", value) for every value of a two-level YAML preset (section: then
// indented key: value; '#' comments; quotes stripped), in file order. An exception of visit comes back as
// std::runtime_error prefixed with "file:line: ". Throws std::runtime_error when the file cannot be read.
void readPresetFile(const std::string& path,
                    const std::function<void(const std::string& key, const std::string& value)>& visit);

// Reads a preset (config/*.yaml) into `config` through the parameter table. Keys of the table's sections
// (graph, cliques, selection, hypotheses, evaluation, refinement, features, and the top-level num_threads)
// must be table keys; an unknown one is an error naming file, line and key. Keys of other sections (a
// tool's benchmark:, say) go to `other`, or are skipped when `other` is empty.
void loadPresetFile(RegistrationConfig& config, const std::string& path,
                    const std::function<void(const std::string& key, const std::string& value)>& other = {});

}  // namespace mac_registration
