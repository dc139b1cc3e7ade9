#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

TEST(TrackingOptions, DefaultsAreValidAndMatchTheBrief) {
  const TrackingOptions o;
  EXPECT_NO_THROW(o.validate());
  EXPECT_EQ(o.num_features, 1000);
  EXPECT_DOUBLE_EQ(o.scale_factor, 1.2);
  EXPECT_EQ(o.num_levels, 8);
  EXPECT_EQ(o.min_inliers, 15);
  EXPECT_DOUBLE_EQ(o.huber_px, 2.0);
}

TEST(TrackingOptions, OutOfRangeFieldIsNamedInTheError) {
  TrackingOptions o;
  o.scale_factor = 1.0;
  try {
    o.validate();
    FAIL() << "scale_factor = 1.0 must be rejected";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("scale_factor"), std::string::npos) << e.what();
  }
  o = TrackingOptions();
  o.min_fast_threshold = o.fast_threshold + 1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = TrackingOptions();
  o.max_depth_m = o.min_depth_m;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = TrackingOptions();
  o.fuse_keyframes = 51;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = TrackingOptions();
  o.fuse_radius_px = 0.0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

// config/tracking.yaml is written by hand, key by key: every key there appears in toString() and
// toString() has no line the file lacks (a field added to the struct but not to the visitor, or
// to the file, fails here).
TEST(TrackingOptions, ToStringListsEveryField) {
  std::ifstream yaml(std::string(DYPHO_SOURCE_DIR) + "/config/tracking.yaml");
  ASSERT_TRUE(yaml.good());
  std::set<std::string> file_keys;
  for (std::string line; std::getline(yaml, line);) {
    const std::size_t colon = line.find(':');
    if (line.empty() || line[0] == '#' || colon == std::string::npos) continue;
    file_keys.insert(line.substr(0, colon));
  }
  std::set<std::string> listed;
  std::istringstream s(TrackingOptions().toString());
  for (std::string line; std::getline(s, line);) listed.insert(line.substr(0, line.find(':')));
  EXPECT_GT(file_keys.size(), 40u);
  EXPECT_EQ(listed, file_keys);
  EXPECT_STREQ(toString(TrackingState::kLost), "LOST");
  EXPECT_STREQ(toString(TrackingState::kOk), "OK");
  EXPECT_STREQ(toString(TrackingState::kNotInitialized), "NOT_INITIALIZED");
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
