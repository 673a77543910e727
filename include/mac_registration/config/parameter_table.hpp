#pragma once

// The one home of the parameters as seen from outside the code: every key of the presets, of the tools'
// --set, of the ROS node's private parameters and of its start-up log is an entry of this table, with its
// type, unit, range and a typed get/set. The node's own parameters (target_mode, tf_mode, ...) are entries
// of the same type in a table of their own (ros/server_config.hpp). ROS-free and PCL-free.

#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "mac_registration/config/feature_params.hpp"
#include "mac_registration/config/relocalization_params.hpp"
#include "mac_registration/core/parameters.hpp"

namespace mac_registration {

// Everything the registration reads: the MAC core's parameters, the PCL front end's and the map
// relocalization's.
struct RegistrationConfig {
  MacParams mac;
  FeatureParams features;
  RelocalizationParams relocalization;
};

enum class ParameterType {
  kReal,     // double
  kInteger,  // a whole number, may be negative in principle (ranges say otherwise)
  kCount,    // a whole number >= 0 (a negative value would wrap around in a size_t)
  kBool,
  kChoice,  // one of `choices`
  kText,    // any name (a frame id)
};

// A value as it comes from a typed source (the ROS parameter server) or is parsed from text.
using ParameterValue = std::variant<bool, long long, double, std::string>;

// What a parameter is, whichever structure holds its value.
struct ParameterInfo {
  std::string key;  // "section.name" as in the presets and --set; the node reads ~section/name
  ParameterType type = ParameterType::kReal;
  std::string unit;  // "m", "s", "count", "x voxel_size", ... ; empty when the value has none
  // Numbers only: the values accepted. The core's parameters take it (and their unit) from
  // macParameterRanges(), so that the core checks what the table documents.
  ParameterRange range;
  std::vector<std::string> choices;  // kChoice only
  std::string doc;                   // one line: what it does and which way to turn it
};

// A parameter of the structure `Config`, with a typed get/set.
template <typename Config>
struct BasicParameter : ParameterInfo {
  std::function<ParameterValue(const Config&)> get;
  // Throws std::invalid_argument (without the key: callers add it) when the value has the wrong type.
  std::function<void(Config&, const ParameterValue&)> set;
};

using Parameter = BasicParameter<RegistrationConfig>;

// Every parameter, in the order of the presets' sections.
const std::vector<Parameter>& parameterTable();

// The entry of `key`, or nullptr.
const Parameter* findParameter(const std::string& key);

// Parses `text` as a value of `parameter`'s type. Throws std::invalid_argument naming the key.
ParameterValue parseParameterValue(const ParameterInfo& parameter, const std::string& text);

// The value as text, as a preset would hold it ("0.99", "true", "gaussian").
std::string formatParameterValue(const ParameterValue& value);

// The refusal of `value` when it is a number outside the parameter's range (outOfRangeMessage()), else "".
std::string rangeProblem(const ParameterInfo& parameter, const ParameterValue& value);

// "key = value [unit]" ("auto" for a 0 that means auto), as the start-up logs list parameters.
std::string describeParameter(const ParameterInfo& parameter, const ParameterValue& value);

// Sets one parameter from text; throws std::invalid_argument naming the key for unknown keys and values
// of the wrong type. Ranges are checked by validateConfig(), which sees all parameters at once.
void setParameter(RegistrationConfig& config, const std::string& key, const std::string& text);

// The same from a typed value (e.g. from the ROS parameter server): a real accepts an integer, a count
// refuses a negative or fractional number, a choice must be one of its names.
void setParameter(RegistrationConfig& config, const std::string& key, const ParameterValue& value);

// One "KEY=VALUE" of a tool's --set.
void applyAssignment(RegistrationConfig& config, const std::string& assignment);

// Every problem with the configuration, each a sentence naming the parameter, its value and the allowed
// range (validateParams() of the core and validateFeatureParams() of the front end); empty when usable.
// The core's distances may be auto (0) here: a cloud registration derives them from the voxel size, and
// the core refuses them only when it is given correspondences alone.
std::vector<std::string> validateConfig(const RegistrationConfig& config);

// Every parameter as "key = value [unit]", one per line, for a start-up log.
std::string describeConfig(const RegistrationConfig& config);

}  // namespace mac_registration
