#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "dypho/mapping/cloud_map_options.h"
#include "dypho/mapping/mapping_options_fields.h"

namespace dypho {
namespace mapping {
namespace DYPHO_UNITY_ID {

TEST(CloudMapOptions, DefaultsAreValidAndDocumentedValues) {
  const CloudMapOptions o;
  EXPECT_NO_THROW(o.validate());
  EXPECT_EQ(o.pixel_stride, 4);
  EXPECT_DOUBLE_EQ(o.min_depth_m, 0.1);
  EXPECT_DOUBLE_EQ(o.max_depth_m, 4.0);
  EXPECT_DOUBLE_EQ(o.voxel_size_m, 0.02);
  EXPECT_EQ(o.max_points, 2000000u);
  const std::string s = o.toString();
  for (const char* key : {"pixel_stride=", "min_depth_m=", "max_depth_m=", "voxel_size_m=", "max_points="}) {
    EXPECT_NE(s.find(key), std::string::npos) << key;
  }
}

TEST(CloudMapOptions, ValidateRejectsEachBadValueAndNamesTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    std::string field;
    std::function<void(CloudMapOptions&)> spoil;
  };
  const std::vector<Case> cases = {
      {"pixel_stride", [](CloudMapOptions& o) { o.pixel_stride = 0; }},
      {"min_depth_m", [](CloudMapOptions& o) { o.min_depth_m = -0.1; }},
      {"min_depth_m", [nan](CloudMapOptions& o) { o.min_depth_m = nan; }},
      {"max_depth_m", [](CloudMapOptions& o) { o.max_depth_m = 0.05; }},
      {"max_depth_m", [](CloudMapOptions& o) { o.max_depth_m = std::numeric_limits<double>::infinity(); }},
      {"voxel_size_m", [](CloudMapOptions& o) { o.voxel_size_m = -0.01; }},
      {"max_points", [](CloudMapOptions& o) { o.max_points = 0; }},
  };
  for (const Case& c : cases) {
    CloudMapOptions o;
    c.spoil(o);
    try {
      o.validate();
      ADD_FAILURE() << "validate() accepted a bad " << c.field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
}

TEST(CloudMapOptions, VisitOptionsCoversEveryFieldOfToString) {
  // visitOptions (the key list used by parameter readers) and toString() must list the same keys.
  CloudMapOptions o;
  const std::string printed = o.toString();
  std::size_t visited = 0;
  visitOptions(o, [&](const char* key, auto& /*field*/, const char* doc) {
    ++visited;
    EXPECT_NE((" " + printed).find(std::string(" ") + key + "="), std::string::npos) << key;
    EXPECT_GT(std::string(doc).size(), 10u) << key;
  });
  std::size_t printed_keys = 0;
  for (char c : printed) printed_keys += c == '=' ? 1 : 0;
  EXPECT_EQ(visited, printed_keys);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mapping
}  // namespace dypho
