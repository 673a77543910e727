// cfg/MacRegistration.cfg against the parameter table: every field names a table key, its default is the
// table's, its bounds never cut off a value the table accepts, and values go both ways unchanged.
#include "mac_registration/ros/reconfigure_mapping.hpp"

#include <gtest/gtest.h>

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

TEST(ReconfigureMapping, EveryFieldIsATableKeyWithTheTablesDefaultAndRoomyBounds) {
  const RegistrationConfig defaults;
  ASSERT_FALSE(MacRegistrationConfig::__getParamDescriptions__().empty());
  for (const auto& description : MacRegistrationConfig::__getParamDescriptions__()) {
    const std::string key = reconfigureKey(description->name);
    ASSERT_FALSE(key.empty()) << description->name << " names no parameter of the table";
    const Parameter& p = *findParameter(key);
    EXPECT_EQ(fieldValue(MacRegistrationConfig::__getDefault__(), description->name),
              numberOf(p.get(defaults)))
        << key;
    // At or outside the table's bounds: dynamic_reconfigure's clamping never turns a refused value into an
    // accepted one, and never refuses one the table accepts.
    const double min = fieldValue(MacRegistrationConfig::__getMin__(), description->name);
    EXPECT_LE(min, p.min) << key;
    // Where 0 means auto, a negative request clamped to 0 would be accepted as auto instead of refused.
    if (p.zero_means_auto) {
      EXPECT_LT(min, 0.0) << key;
    }
    const double max = fieldValue(MacRegistrationConfig::__getMax__(), description->name);
    const bool unbounded_int = description->type == "int" && max == std::numeric_limits<int>::max();
    EXPECT_TRUE(max >= p.max || unbounded_int) << key << ": .cfg max " << max << ", table max " << p.max;
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
