#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "dypho/tracking/tracking_options.h"
#include "dypho/tracking/tracking_result.h"

namespace dypho {
namespace tracking {
namespace {

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
}

TEST(TrackingOptions, ToStringListsEveryField) {
  const std::string s = TrackingOptions().toString();
  for (const char* key : {"num_features", "ratio_test", "ransac_iterations", "outlier_rounds",
                          "keyframe_max_frames", "max_lost_frames"}) {
    EXPECT_NE(s.find(std::string(key) + ": "), std::string::npos) << key;
  }
  EXPECT_STREQ(toString(TrackingState::kLost), "LOST");
  EXPECT_STREQ(toString(TrackingState::kOk), "OK");
  EXPECT_STREQ(toString(TrackingState::kNotInitialized), "NOT_INITIALIZED");
}

}  // namespace
}  // namespace tracking
}  // namespace dypho
