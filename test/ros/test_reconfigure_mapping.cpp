// cfg/MacRegistration.cfg against the parameter table: every field names a table key, its default is the
// table's, it holds no range of its own (a value outside the table's is refused with the table's words),
// and values go both ways unchanged.
#include "mac_registration/ros/reconfigure_mapping.hpp"

#include <gtest/gtest.h>

#include <dynamic_reconfigure/Config.h>

#include <cmath>
#include <limits>

namespace mac_registration {
namespace {

double numberOf(const ParameterValue& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* i = std::get_if<long long>(&v)) return double(*i);
  return NAN;
}

// The field's value in a generated config (default, min or max), as a number.
double fieldValue(const MacRegistrationConfig& fields, const std::string& field) {
  for (const auto& description : MacRegistrationConfig::__getParamDescriptions__()) {
    if (description->name != field) continue;
    boost::any value;
    description->getValue(fields, value);
    if (const double* d = boost::any_cast<double>(&value)) return *d;
    if (const int* i = boost::any_cast<int>(&value)) return *i;
  }
  return NAN;
}

// The .cfg field of a table key.
std::string fieldOf(const std::string& key) {
  std::string field = key;
  for (char& c : field) c = c == '.' ? '_' : c;
  return field;
}

TEST(ReconfigureMapping, EveryFieldIsATableKeyWithTheTablesDefaultAndNoRangeOfItsOwn) {
  const RegistrationConfig defaults;
  ASSERT_FALSE(MacRegistrationConfig::__getParamDescriptions__().empty());
  for (const auto& description : MacRegistrationConfig::__getParamDescriptions__()) {
    const std::string key = reconfigureKey(description->name);
    ASSERT_FALSE(key.empty()) << description->name << " names no parameter of the table";
    const Parameter& p = *findParameter(key);
    EXPECT_EQ(fieldValue(MacRegistrationConfig::__getDefault__(), description->name),
              numberOf(p.get(defaults)))
        << key;
    // The .cfg's bounds are its types' own: the range is the table's alone, and dynamic_reconfigure never
    // clamps a request into something else than what was asked for.
    const double min = fieldValue(MacRegistrationConfig::__getMin__(), description->name);
    const double max = fieldValue(MacRegistrationConfig::__getMax__(), description->name);
    if (description->type == "int") {
      EXPECT_EQ(min, std::numeric_limits<int>::min()) << key;
      EXPECT_EQ(max, std::numeric_limits<int>::max()) << key;
    } else {
      EXPECT_EQ(min, -std::numeric_limits<double>::infinity()) << key;
      EXPECT_EQ(max, std::numeric_limits<double>::infinity()) << key;
    }
  }
}

// A request outside a table range reaches the node as asked and is refused with the table's words.
TEST(ReconfigureMapping, ARequestOutsideTheRangeIsRefusedWithTheTablesMessage) {
  for (const auto& key : reconfigurableKeys()) {
    const Parameter& p = *findParameter(key);
    const double outside = std::isfinite(p.range.min) ? p.range.min - 1.0 : p.range.max + 1.0;
    MacRegistrationConfig fields = MacRegistrationConfig::__getDefault__();
    dynamic_reconfigure::Config message;
    fields.__toMessage__(message);
    for (auto& d : message.doubles) {
      if (d.name == fieldOf(key)) d.value = outside;
    }
    for (auto& i : message.ints) {
      if (i.name == fieldOf(key)) i.value = static_cast<int>(outside);
    }
    fields.__fromMessage__(message);
    RegistrationConfig config;
    fromReconfigure(fields, config);
    const auto problems = validateConfig(config);
    ASSERT_EQ(problems.size(), 1u) << key;
    EXPECT_EQ(problems[0], rangeProblem(p, p.get(config))) << key;
  }
}

TEST(ReconfigureMapping, ValuesGoBothWaysUnchanged) {
  RegistrationConfig config;
  config.mac.graph.t_cmp = 0.995;
  config.mac.evaluation.min_inliers = 42;
  config.features.voxel_size = 0.3;
  MacRegistrationConfig fields = MacRegistrationConfig::__getDefault__();
  toReconfigure(config, fields);
  EXPECT_DOUBLE_EQ(fields.graph_t_cmp, 0.995);
  EXPECT_EQ(fields.evaluation_min_inliers, 42);
  EXPECT_DOUBLE_EQ(fields.features_voxel_size, 0.3);
  RegistrationConfig back;
  fromReconfigure(fields, back);
  for (const auto& key : reconfigurableKeys()) {
    EXPECT_EQ(formatParameterValue(findParameter(key)->get(back)),
              formatParameterValue(findParameter(key)->get(config)))
        << key;
  }
  fields.evaluation_min_inliers = -1;  // the .cfg lets it through; the table refuses it
  EXPECT_THROW(fromReconfigure(fields, back), std::invalid_argument);
}

}  // namespace
}  // namespace mac_registration
