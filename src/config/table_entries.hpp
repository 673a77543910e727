#pragma once

// Builders of parameter-table entries, shared by the algorithm's table (src/config/parameter_table.cpp) and
// the ROS node's (src/ros/server_config.cpp): a member accessor gives an entry its get and set, so that an
// entry is one line of facts. Private to the package's libraries.

#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {
namespace table_entries {

// The typed views of a value; each refuses what its type cannot hold.
inline double asReal(const ParameterValue& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* i = std::get_if<long long>(&v)) return double(*i);
  throw std::invalid_argument("expected a number");
}

inline long long asInteger(const ParameterValue& v) {
  const double d = asReal(v);
  if (!std::isfinite(d) || d != std::floor(d) || std::fabs(d) > 1e15)
    throw std::invalid_argument("expected a whole number");
  return static_cast<long long>(d);
}

inline std::size_t asCount(const ParameterValue& v) {
  const long long i = asInteger(v);
  // A negative count would wrap around to a huge size_t and pass every range check.
  if (i < 0) throw std::invalid_argument("expected a count (>= 0)");
  return static_cast<std::size_t>(i);
}

inline bool asBool(const ParameterValue& v) {
  if (const auto* b = std::get_if<bool>(&v)) return *b;
  throw std::invalid_argument("expected true or false");
}

inline const std::string& asText(const ParameterValue& v) {
  if (const auto* s = std::get_if<std::string>(&v)) return *s;
  throw std::invalid_argument("expected a name");
}

// An enum field and its names, both ways.
template <typename Enum>
struct Names {
  std::vector<std::pair<std::string, Enum>> pairs;

  Enum parse(const ParameterValue& v) const {
    const std::string& text = asText(v);
    for (const auto& [name, value] : pairs) {
      if (name == text) return value;
    }
    throw std::invalid_argument("'" + text + "' is not one of " + list());
  }
  std::string name(Enum value) const {
    for (const auto& [n, e] : pairs) {
      if (e == value) return n;
    }
    return "?";
  }
  std::vector<std::string> all() const {
    std::vector<std::string> names;
    for (const auto& pair : pairs) names.push_back(pair.first);
    return names;
  }
  std::string list() const {
    std::string text;
    for (const auto& n : all()) text += (text.empty() ? "" : ", ") + n;
    return text;
  }
};

template <typename Config>
BasicParameter<Config> facts(std::string key, ParameterType type, std::string unit, ParameterRange range,
                             std::string doc) {
  BasicParameter<Config> p;
  p.key = std::move(key);
  p.type = type;
  p.unit = std::move(unit);
  p.range = std::move(range);
  p.doc = std::move(doc);
  return p;
}

// A number: its field is read as a double (reals) or an integer, and written through `convert` (asReal,
// asInteger or asCount), which refuses what the field's type cannot hold.
template <typename Config, typename Field, typename Convert>
BasicParameter<Config> numeric(ParameterType type, std::string key, Field field, Convert convert,
                               std::string unit, ParameterRange range, std::string doc) {
  auto p = facts<Config>(std::move(key), type, std::move(unit), std::move(range), std::move(doc));
  p.get = [field, type](const Config& c) -> ParameterValue {
    if (type == ParameterType::kReal) return double(field(c));
    return static_cast<long long>(field(c));
  };
  // A 0 that means auto may also be written "auto".
  const bool automatic = p.range.zero == ParameterRange::Zero::kAuto;
  p.set = [field, convert, automatic](Config& c, const ParameterValue& v) {
    using Value = std::decay_t<decltype(field(c))>;
    const auto* text = std::get_if<std::string>(&v);
    field(c) = static_cast<Value>(automatic && text && *text == "auto" ? 0.0 : convert(v));
  };
  return p;
}

template <typename Config, typename Field>
BasicParameter<Config> real(std::string key, Field field, std::string unit, ParameterRange range,
                            std::string doc) {
  return numeric<Config>(ParameterType::kReal, std::move(key), field, asReal, std::move(unit),
                         std::move(range), std::move(doc));
}

template <typename Config, typename Field>
BasicParameter<Config> integer(std::string key, Field field, std::string unit, ParameterRange range,
                               std::string doc) {
  return numeric<Config>(ParameterType::kInteger, std::move(key), field, asInteger, std::move(unit),
                         std::move(range), std::move(doc));
}

template <typename Config, typename Field>
BasicParameter<Config> count(std::string key, Field field, std::string unit, ParameterRange range,
                             std::string doc) {
  return numeric<Config>(ParameterType::kCount, std::move(key), field, asCount, std::move(unit),
                         std::move(range), std::move(doc));
}

template <typename Config, typename Field>
BasicParameter<Config> boolean(std::string key, Field field, std::string doc) {
  auto p = facts<Config>(std::move(key), ParameterType::kBool, "", {}, std::move(doc));
  p.get = [field](const Config& c) -> ParameterValue { return bool(field(c)); };
  p.set = [field](Config& c, const ParameterValue& v) { field(c) = asBool(v); };
  return p;
}

template <typename Config, typename Field>
BasicParameter<Config> text(std::string key, Field field, std::string doc) {
  auto p = facts<Config>(std::move(key), ParameterType::kText, "", {}, std::move(doc));
  p.get = [field](const Config& c) -> ParameterValue { return std::string(field(c)); };
  p.set = [field](Config& c, const ParameterValue& v) { field(c) = asText(v); };
  return p;
}

// `names` must outlive the entry (a static of the table's source).
template <typename Config, typename Enum, typename Field>
BasicParameter<Config> choice(std::string key, Field field, const Names<Enum>& names, std::string doc) {
  auto p = facts<Config>(std::move(key), ParameterType::kChoice, "", {}, std::move(doc));
  p.choices = names.all();
  p.get = [field, &names](const Config& c) -> ParameterValue { return names.name(field(c)); };
  p.set = [field, &names](Config& c, const ParameterValue& v) { field(c) = names.parse(v); };
  return p;
}

}  // namespace table_entries
}  // namespace mac_registration

// A generic accessor: the same lambda reads a const structure and writes a mutable one.
#define MAC_FIELD(path) \
  [](auto& c) -> auto& { return c.path; }
