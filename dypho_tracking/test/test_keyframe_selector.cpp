#include <cmath>

#include <gtest/gtest.h>

#include "dypho/tracking/keyframe_selector.h"

namespace dypho {
namespace tracking {
namespace {

Eigen::Isometry3d pose(double tx, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(tx, 0, 0);
  return T;
}

TEST(KeyframeSelector, DecidesOnEachCriterion) {
  TrackingOptions o;  // 0.10 m, 8 deg, ratio 0.6, 20 frames
  const KeyframeSelector s(o);
  const Eigen::Isometry3d kf = pose(1.0, 30.0);  // keyframe not at the origin: relative motion counts

  // Small motion, well tracked, few frames: no keyframe.
  EXPECT_FALSE(s.decide(kf, kf * pose(0.05, 3.0), 400, 500, 5).is_keyframe);
  // Translation above 0.10 m.
  auto d = s.decide(kf, kf * pose(0.11, 0.0), 400, 500, 5);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("translation"), std::string::npos) << d.reason;
  // Rotation above 8 deg.
  d = s.decide(kf, kf * pose(0.0, 8.5), 400, 500, 5);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("rotation"), std::string::npos) << d.reason;
  // Just under both thresholds.
  EXPECT_FALSE(s.decide(kf, kf * pose(0.099, 7.9), 400, 500, 5).is_keyframe);
  // Tracked ratio 250 / 500 = 0.5 < 0.6.
  d = s.decide(kf, kf, 250, 500, 5);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("ratio"), std::string::npos) << d.reason;
  // Frame gap.
  EXPECT_FALSE(s.decide(kf, kf, 400, 500, 19).is_keyframe);
  d = s.decide(kf, kf, 400, 500, 20);
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_NE(d.reason.find("frames"), std::string::npos) << d.reason;
  // Keyframe without points: ratio 0 -> keyframe.
  EXPECT_TRUE(s.decide(kf, kf, 0, 0, 1).is_keyframe);
}

}  // namespace
}  // namespace tracking
}  // namespace dypho
