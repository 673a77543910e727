// The parameter table: presets, --set, typed values, and its documented bounds against the validators.
#include "mac_registration/config/parameter_table.hpp"

#include <gtest/gtest.h>

#include <cmath>
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

// The defaults are usable, and each documented numeric bound is the validators' bound: just outside is
// refused with a message naming the key, just inside is not refused for that key.
TEST(ParameterTable, DocumentedBoundsAreTheValidatorsBounds) {
  ASSERT_TRUE(validateConfig(RegistrationConfig{}).empty());
  for (const auto& p : parameterTable()) {
    if (p.type == ParameterType::kBool || p.type == ParameterType::kChoice) continue;
    const bool whole = p.type != ParameterType::kReal;
    const double step = whole ? 1.0 : 1e-6 * std::max(1.0, std::fabs(p.min));
    const auto problemsAt = [&](double value) {
      RegistrationConfig config;
      // Partners of cross-parameter rules at values that let this one reach its own bound.
      config.features.normal_radius_factor = 1e-7;
      config.mac.cliques.min_clique_size = 3;
      setParameter(config, p.key,
                   whole ? ParameterValue(static_cast<long long>(value)) : ParameterValue(value));
      return validateConfig(config);
    };
    const std::string& name = p.key;
    if (std::isfinite(p.min) && !(p.type == ParameterType::kCount && p.min == 0.0)) {
      const double below = p.min - step;
      if (!(p.zero_means_off && below == 0.0)) {
        EXPECT_TRUE(mentions(problemsAt(below), name)) << p.key << " below";
      }
      const double inside = whole ? p.min : p.min + step;
      EXPECT_FALSE(mentions(problemsAt(inside), name)) << p.key << " at its minimum";
    }
    if (std::isfinite(p.max)) {
      EXPECT_TRUE(mentions(problemsAt(p.max + step), name)) << p.key << " above";
      EXPECT_FALSE(mentions(problemsAt(whole ? p.max : p.max - step), name)) << p.key << " at its maximum";
    }
    if (p.zero_means_off || p.zero_means_auto) {
      EXPECT_FALSE(mentions(problemsAt(0.0), name)) << p.key << " = 0 (off or auto)";
    }
  }
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
