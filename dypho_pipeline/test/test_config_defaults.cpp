/// Configuration and output paths. Each YAML in config/ lists every option of its module with the built-in default: the
/// same set of keys, and each value equal to the default. (The YAML is what roslaunch loads and what dypho_run_dataset
/// reads first; a drift would make the ROS graph and the README disagree with the code.)

#include <cmath>
#include <set>
#include <string>
#include <type_traits>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "dypho/common/output_path.h"
#include "dypho/mapping/mapping_options_fields.h"
#include "dypho/mask/mask_options_fields.h"
#include "dypho/tracking/tracking_options_fields.h"

namespace DYPHO_UNITY_ID {

/// Compares every visited field with the same key of a YAML map; records the keys it saw.
class DefaultsMatchYaml {
 public:
  explicit DefaultsMatchYaml(YAML::Node node) : node_(std::move(node)) {}

  template <typename T>
  void operator()(const std::string& key, T& value, const char* /*doc*/) {
    keys_.insert(key);
    if (!node_[key]) {
      ADD_FAILURE() << key << " missing from the YAML";
      return;
    }
    const T from_yaml = node_[key].as<T>();
    if constexpr (std::is_floating_point_v<T>) {
      EXPECT_NEAR(from_yaml, value, 1e-12 * std::max(1.0, std::abs(static_cast<double>(value)))) << key;
    } else {
      EXPECT_EQ(from_yaml, value) << key;
    }
  }

  const std::set<std::string>& keys() const { return keys_; }

 private:
  YAML::Node node_;
  std::set<std::string> keys_;
};

std::set<std::string> yamlKeys(const YAML::Node& node) {
  std::set<std::string> keys;
  for (const auto& kv : node) keys.insert(kv.first.as<std::string>());
  return keys;
}

template <typename Options>
void expectYamlEqualsDefaults(const std::string& file) {
  const YAML::Node node = YAML::LoadFile(std::string(DYPHO_SOURCE_DIR) + "/config/" + file);
  ASSERT_TRUE(node.IsMap()) << file;
  Options defaults;
  DefaultsMatchYaml check(node);
  visitOptions(defaults, check);
  EXPECT_EQ(check.keys(), yamlKeys(node)) << file << ": keys differ from the options' fields";
  EXPECT_GT(check.keys().size(), 10u);
}

TEST(ConfigDefaults, MaskYamlEqualsBuiltInDefaults) {
  using dypho::mask::visitOptions;
  expectYamlEqualsDefaults<dypho::mask::DynamicMaskOptions>("mask.yaml");
}

TEST(ConfigDefaults, TrackingYamlEqualsBuiltInDefaults) {
  using dypho::tracking::visitOptions;
  expectYamlEqualsDefaults<dypho::tracking::TrackingOptions>("tracking.yaml");
}

TEST(ConfigDefaults, MappingYamlEqualsBuiltInDefaults) {
  using dypho::mapping::visitOptions;
  expectYamlEqualsDefaults<dypho::mapping::MappingOptions>("mapping.yaml");
}

}  // namespace DYPHO_UNITY_ID

// Services write only under the configured output directory.

namespace DYPHO_UNITY_ID {

TEST(OutputDirectory, RequestsStayInsideTheOutputDirectory) {
  const std::string base = "/tmp/dypho_output_test/base";
  EXPECT_EQ(dypho::resolveOutputDirectory(base, ""), base);
  EXPECT_EQ(dypho::resolveOutputDirectory(base, "run1"), base + "/run1");
  EXPECT_EQ(dypho::resolveOutputDirectory(base, "run1/../run2"), base + "/run2");
  EXPECT_EQ(dypho::resolveOutputDirectory(base, base + "/abs"), base + "/abs");
  EXPECT_THROW(dypho::resolveOutputDirectory(base, ".."), std::invalid_argument);
  EXPECT_THROW(dypho::resolveOutputDirectory(base, "../base_sibling"), std::invalid_argument);
  EXPECT_THROW(dypho::resolveOutputDirectory(base, "run1/../../x"), std::invalid_argument);
  EXPECT_THROW(dypho::resolveOutputDirectory(base, "/etc"), std::invalid_argument);
  EXPECT_THROW(dypho::resolveOutputDirectory(base, "/tmp/dypho_output_test/basement"), std::invalid_argument);
  EXPECT_THROW(dypho::resolveOutputDirectory("", "x"), std::invalid_argument);
}

}  // namespace DYPHO_UNITY_ID
