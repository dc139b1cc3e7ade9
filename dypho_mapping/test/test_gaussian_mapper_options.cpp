/// Mapping options: config/mapping.yaml lists every key with the built-in default, in struct
/// order; validate() rejects out-of-range values naming the field.
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "dypho/mapping/mapping_options_fields.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

TEST(MappingOptions, ConfigFileHasEveryKeyWithItsDefaultInOrder) {
  const YAML::Node yaml = YAML::LoadFile(std::string(DYPHO_SOURCE_DIR) + "/config/mapping.yaml");
  MappingOptions defaults;
  std::vector<std::string> keys;
  visitOptions(defaults, [&](const char* key, auto& value, const char* doc) {
    keys.push_back(key);
    EXPECT_GT(std::string(doc).size(), 10u) << key;
    ASSERT_TRUE(yaml[key]) << "config/mapping.yaml lacks key " << key;
    using T = std::decay_t<decltype(value)>;
    EXPECT_EQ(yaml[key].as<T>(), value) << key;  // file value == built-in default
  });
  std::vector<std::string> file_keys;
  for (const auto& kv : yaml) file_keys.push_back(kv.first.as<std::string>());
  EXPECT_EQ(file_keys, keys);  // same keys, same order, nothing unknown
}

TEST(MappingOptions, DefaultsValidateAndBadValuesNameTheField) {
  GaussianMapperOptions o;
  EXPECT_NO_THROW(o.validate());
  const std::string printed = o.toString();
  EXPECT_NE(printed.find("lambda_depth=0.7"), std::string::npos) << printed;
  auto expectBad = [](GaussianMapperOptions bad, const std::string& field) {
    try {
      bad.validate();
      FAIL() << field << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  GaussianMapperOptions b = o;
  b.sh_degree = 4;
  expectBad(b, "sh_degree");
  b = o;
  b.train_downsample = 3;
  expectBad(b, "train_downsample");
  b = o;
  b.lambda_depth = 1.5;
  expectBad(b, "lambda_depth");
  b = o;
  b.max_gaussians = 0;
  expectBad(b, "max_gaussians");
  b = o;
  b.initial_opacity = 1.0;
  expectBad(b, "initial_opacity");
  b = o;
  b.ssim_weight = -0.1;
  expectBad(b, "ssim_weight");
  b = o;
  b.final_refine_iterations = -1;
  expectBad(b, "final_refine_iterations");
  b = o;
  b.live_cpu_training_duty = 0.0;
  expectBad(b, "live_cpu_training_duty");
  b = o;
  b.live_cpu_training_duty = 1.5;
  expectBad(b, "live_cpu_training_duty");
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
