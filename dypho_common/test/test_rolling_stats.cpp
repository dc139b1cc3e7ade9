/// RollingSamples and EventRate (the live diagnostics' percentiles and input rate).

#include <gtest/gtest.h>

#include "dypho/common/rolling_stats.h"

namespace DYPHO_UNITY_ID {

TEST(RollingStats, PercentilesOfTheNewestSamples) {
  dypho::RollingSamples s(100);
  EXPECT_EQ(s.percentile(0.5), 0.0) << "no samples";
  for (int i = 1; i <= 200; ++i) s.add(i);  // keeps 101..200
  EXPECT_EQ(s.size(), 100u);
  EXPECT_EQ(s.percentile(0.5), 150.0);
  EXPECT_EQ(s.percentile(0.95), 195.0);
  EXPECT_EQ(s.percentile(1.0), 200.0);
  EXPECT_EQ(s.percentile(0.0), 101.0);
  s.add(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(s.size(), 100u) << "non-finite samples are ignored";
}

TEST(RollingStats, RateOverTheWindow) {
  dypho::EventRate r(1.0);
  EXPECT_EQ(r.rateHz(0.0), 0.0);
  for (int i = 0; i <= 30; ++i) r.add(i / 30.0);  // 30 Hz for one second
  EXPECT_NEAR(r.rateHz(1.0), 30.0, 1e-9);
  EXPECT_EQ(r.rateHz(5.0), 0.0) << "events older than the window are forgotten";
}

}  // namespace DYPHO_UNITY_ID
