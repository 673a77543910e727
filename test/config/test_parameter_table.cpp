// The parameter table: presets, --set, typed values, and its documented bounds against the validators.
#include "mac_registration/config/parameter_table.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "mac_registration/config/preset_file.hpp"
#include "temp_dir.hpp"

namespace mac_registration {
namespace {

std::string configPath(const std::string& name) { return std::string(MAC_CONFIG_DIR) + "/" + name; }

bool mentions(const std::vector<std::string>& problems, const std::string& key) {
  for (const auto& p : problems) {
    if (p.find(key) != std::string::npos) return true;
  }
  return false;
}

TEST(ParameterTable, KeysAreUniqueAndDocumented) {
  std::set<std::string> keys;
  for (const auto& p : parameterTable()) {
    EXPECT_TRUE(keys.insert(p.key).second) << "duplicate key " << p.key;
    EXPECT_FALSE(p.doc.empty()) << p.key;
    EXPECT_EQ(findParameter(p.key), &p);
  }
  EXPECT_EQ(findParameter("graph.nonsense"), nullptr);
}

TEST(ParameterTable, EveryValueRoundTripsThroughText) {
  const RegistrationConfig defaults;
  for (const auto& p : parameterTable()) {
    RegistrationConfig config;
    setParameter(config, p.key, formatParameterValue(p.get(defaults)));
    EXPECT_EQ(formatParameterValue(p.get(config)), formatParameterValue(p.get(defaults))) << p.key;
  }
}

// The defaults are usable, and each range is the validators' range: just outside a bound, or at an open
// one, is refused with a message naming the key; at a closed bound, or just inside an open one, it is not.
TEST(ParameterTable, RangesAreTheValidatorsRanges) {
  ASSERT_TRUE(validateConfig(RegistrationConfig{}).empty());
  for (const auto& p : parameterTable()) {
    if (p.type == ParameterType::kBool || p.type == ParameterType::kChoice) continue;
    const ParameterRange& r = p.range;
    const bool whole = p.type != ParameterType::kReal;
    const auto problemsAt = [&](double value) {
      RegistrationConfig config;
      // Partners of cross-parameter rules at values that let this one reach its own bound.
      config.features.normal_radius_factor = 1e-7;
      config.mac.cliques.min_clique_size = 3;
      setParameter(config, p.key,
                   whole ? ParameterValue(static_cast<long long>(value)) : ParameterValue(value));
      return validateConfig(config);
    };
    const auto refused = [&](double value) { return mentions(problemsAt(value), p.key); };
    const auto step = [&](double bound) { return whole ? 1.0 : 1e-6 * std::max(1.0, std::fabs(bound)); };
    if (std::isfinite(r.min) && !(p.type == ParameterType::kCount && r.min == 0.0)) {
      const double below = r.min - step(r.min);
      if (!(below == 0.0 && r.zero != ParameterRange::Zero::kPlain)) {
        EXPECT_TRUE(refused(below)) << p.key << " below";
      }
      const bool zero_accepted = r.min == 0.0 && r.zero != ParameterRange::Zero::kPlain;
      EXPECT_EQ(refused(r.min), r.min_open && !zero_accepted) << p.key << " at its minimum";
      EXPECT_FALSE(refused(r.min + step(r.min))) << p.key << " inside its minimum";
    }
    if (std::isfinite(r.max)) {
      EXPECT_TRUE(refused(r.max + step(r.max))) << p.key << " above";
      EXPECT_EQ(refused(r.max), r.max_open) << p.key << " at its maximum";
      EXPECT_FALSE(refused(r.max - step(r.max))) << p.key << " inside its maximum";
    }
    if (r.zero != ParameterRange::Zero::kPlain) {
      EXPECT_FALSE(mentions(problemsAt(0.0), p.key)) << p.key << " = 0 (off or auto)";
    }
    if (!whole) {
      // Infinity only where it means something (a lifted bound).
      EXPECT_EQ(refused(std::numeric_limits<double>::infinity()), !(std::isinf(r.max) && !r.max_open))
          << p.key << " = inf";
      EXPECT_TRUE(refused(std::numeric_limits<double>::quiet_NaN())) << p.key << " = NaN";
    }
  }
}

// The core checks its parameters without the table: both read one schema, so each core range and unit is
// written once, and the table lists every one of them.
TEST(ParameterTable, CoreParametersTakeTheCoresRanges) {
  for (const auto& core : macParameterRanges()) {
    const Parameter* p = findParameter(core.key);
    ASSERT_NE(p, nullptr) << core.key;
    EXPECT_EQ(p->unit, core.unit) << core.key;
    EXPECT_EQ(p->range.text(), core.range.text()) << core.key;
    EXPECT_EQ(core.value(RegistrationConfig{}.mac), std::stod(formatParameterValue(p->get({})))) << core.key;
  }
}

// A refusal names the key, the value with its unit, the range and the hint.
TEST(ParameterTable, RefusalsSayKeyValueRangeAndHint) {
  RegistrationConfig config;
  config.mac.graph.t_cmp = 1.5;
  config.features.voxel_size = -0.05;
  config.features.feature_radius_factor = 1.0;  // below features.normal_radius_factor 2
  const auto problems = validateConfig(config);
  ASSERT_EQ(problems.size(), 3u);
  EXPECT_EQ(
      problems[0],
      "graph.t_cmp = 1.5 is out of range: must be in (0, 1); 0.99 is the paper's default, lower it for few "
      "or very noisy correspondences.");
  EXPECT_EQ(
      problems[1],
      "features.voxel_size = -0.05 [m] is out of range: must be > 0 (0 = auto, the leaf that leaves about "
      "5000 keypoints in a cloud).");
  EXPECT_EQ(problems[2],
            "features.feature_radius_factor = 1 [x voxel_size] is out of range: must be > "
            "features.normal_radius_factor (2).");
  EXPECT_EQ(findParameter("cliques.max_clique_size")->range.text(), ">= 3 (0 = no cap)");
  EXPECT_EQ(findParameter("selection.normal_consistency_threshold")->range.text(), "in (0, 1]");
}

TEST(ParameterTable, TypedValuesAreChecked) {
  RegistrationConfig config;
  setParameter(config, "graph.t_cmp", ParameterValue(1LL));  // an integer where a real is expected is fine
  EXPECT_DOUBLE_EQ(config.mac.graph.t_cmp, 1.0);
  EXPECT_THROW(setParameter(config, "graph.t_cmp", ParameterValue(std::string("high"))),
               std::invalid_argument);
  EXPECT_THROW(setParameter(config, "graph.second_order", ParameterValue(1.0)), std::invalid_argument);
  EXPECT_THROW(setParameter(config, "cliques.max_cliques", ParameterValue(2.5)), std::invalid_argument);
  // A negative count would wrap to a huge size_t and pass every range check.
  EXPECT_THROW(setParameter(config, "evaluation.min_inliers", ParameterValue(-1LL)), std::invalid_argument);
  EXPECT_THROW(setParameter(config, "evaluation.metric", ParameterValue(std::string("median"))),
               std::invalid_argument);
  setParameter(config, "evaluation.metric", ParameterValue(std::string("inlier_count")));
  EXPECT_EQ(config.mac.evaluation.metric, ScoreMetric::kInlierCount);
}

TEST(ParameterTable, NumThreadsMeansOneThing) {
  RegistrationConfig config;
  setParameter(config, "num_threads", std::string("1"));
  EXPECT_EQ(config.mac.num_threads, 1);
  EXPECT_EQ(config.features.num_threads, 1);
  EXPECT_EQ(findParameter("features.num_threads"), nullptr);
}

TEST(ParameterTable, DescriptionListsEveryParameterWithItsUnit) {
  const std::string text = describeConfig(RegistrationConfig{});
  for (const auto& p : parameterTable()) EXPECT_NE(text.find(p.key + " = "), std::string::npos) << p.key;
  EXPECT_NE(text.find("features.voxel_size = 0.05 [m]"), std::string::npos) << text;
}

TEST(Presets, IndoorPresetIsReadWhole) {
  RegistrationConfig config;
  config.features.voxel_size = 1.0;  // anything the preset must overwrite
  std::vector<std::string> others;
  loadPresetFile(config, configPath("indoor_rgbd.yaml"),
                 [&](const std::string& key, const std::string&) { others.push_back(key); });
  EXPECT_DOUBLE_EQ(config.features.voxel_size, 0.05);
  EXPECT_DOUBLE_EQ(config.features.feature_radius_factor, 5.0);
  EXPECT_EQ(config.features.max_correspondences, 5000u);
  EXPECT_DOUBLE_EQ(config.mac.graph.t_cmp, 0.99);
  EXPECT_TRUE(validateConfig(config).empty());
  // Only the benchmark's criterion is left to other readers.
  for (const auto& key : others) EXPECT_EQ(key.rfind("benchmark.", 0), 0u) << key;
}

TEST(Presets, OutdoorPresetIsReadWhole) {
  RegistrationConfig config;
  loadPresetFile(config, configPath("outdoor_lidar.yaml"));
  EXPECT_DOUBLE_EQ(config.features.voxel_size, 0.5);
  EXPECT_EQ(config.mac.graph.score, CompatibilityScore::kQuadratic);
  EXPECT_EQ(config.mac.cliques.min_clique_size, 4);
  EXPECT_TRUE(validateConfig(config).empty());
}

// One setting for every scale: the voxel size and the distances derived from it are "auto" (0).
TEST(Presets, ObjectPresetDerivesItsDistances) {
  RegistrationConfig config;
  loadPresetFile(config, configPath("object_scan.yaml"));
  EXPECT_EQ(config.features.voxel_size, 0.0);
  EXPECT_EQ(config.mac.graph.gaussian_sigma, 0.0);
  EXPECT_EQ(config.mac.graph.quadratic_threshold, 0.0);
  EXPECT_EQ(config.mac.evaluation.inlier_threshold, 0.0);
  EXPECT_TRUE(validateConfig(config).empty());
  const std::string text = describeConfig(config);
  EXPECT_NE(text.find("features.voxel_size = auto [m]"), std::string::npos) << text;
  EXPECT_NE(text.find("evaluation.inlier_threshold = auto [m]"), std::string::npos) << text;
  // By hand: one number, and "auto" back; words other than auto are still refused.
  applyAssignment(config, "features.voxel_size=0.003");
  EXPECT_DOUBLE_EQ(config.features.voxel_size, 0.003);
  setParameter(config, "features.voxel_size", ParameterValue(std::string("auto")));
  EXPECT_EQ(config.features.voxel_size, 0.0);
  EXPECT_THROW(applyAssignment(config, "features.voxel_size=big"), std::invalid_argument);
  EXPECT_THROW(applyAssignment(config, "graph.t_cmp=auto"), std::invalid_argument);
}

TEST(Presets, OtherSectionsGoToTheirOwnReader) {
  test::TempDir dir;
  const std::string path = dir.write("preset.yaml",
                                     "graph:\n  t_cmp: 0.995\n"
                                     "features:\n  voxel_size: 0.02  # [m]\n  mutual_filter: true\n"
                                     "ros_node:\n  frame: map\n");
  RegistrationConfig config;
  std::string other;
  loadPresetFile(config, path,
                 [&](const std::string& key, const std::string& value) { other = key + "=" + value; });
  EXPECT_DOUBLE_EQ(config.mac.graph.t_cmp, 0.995);
  EXPECT_DOUBLE_EQ(config.features.voxel_size, 0.02);
  EXPECT_TRUE(config.features.mutual_filter);
  EXPECT_EQ(other, "ros_node.frame=map");
}

TEST(Presets, ErrorsNameFileLineAndKey) {
  test::TempDir dir;
  const std::string path = dir.write("bad.yaml", "features:\n  voxel_size: 0.05\n  voxel_sise: 0.05\n");
  RegistrationConfig config;
  try {
    loadPresetFile(config, path);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("features.voxel_sise"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadPresetFile(config, dir.file("missing.yaml")), std::runtime_error);
}

TEST(Assignments, SetTheNamedParameter) {
  RegistrationConfig config;
  applyAssignment(config, "features.voxel_size=0.3");
  applyAssignment(config, "graph.t_cmp=0.9");
  applyAssignment(config, "features.ratio_test=0.8");
  EXPECT_DOUBLE_EQ(config.features.voxel_size, 0.3);
  EXPECT_DOUBLE_EQ(config.features.ratio_test, 0.8);
  EXPECT_DOUBLE_EQ(config.mac.graph.t_cmp, 0.9);
  EXPECT_THROW(applyAssignment(config, "features.voxel_size"), std::invalid_argument);  // no '='
  EXPECT_THROW(applyAssignment(config, "features.nonsense=1"), std::invalid_argument);  // unknown
  EXPECT_THROW(applyAssignment(config, "features.mutual_filter=maybe"), std::invalid_argument);
  EXPECT_THROW(applyAssignment(config, "features.max_correspondences=-1"), std::invalid_argument);
  EXPECT_THROW(applyAssignment(config, "cliques.max_cliques=2.5"), std::invalid_argument);
}

}  // namespace
}  // namespace mac_registration
