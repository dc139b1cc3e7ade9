/// ConstantVelocityModel: the prediction from the last step scaled by time, its reset rules, and
/// a correction of the earlier poses that is not taken for motion.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "dypho/common/motion_prior.h"

namespace DYPHO_UNITY_ID {

using namespace dypho;

Eigen::Isometry3d poseAt(double x_m, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, 0.0, 0.0);
  return T;
}

constexpr Timestamp kFrameNs = 33'333'333;  // 30 Hz

TEST(ConstantVelocityModel, PredictsScaledByTime) {
  ConstantVelocityModel model;
  model.observe({0, poseAt(0.0, 0.0), true, false});
  EXPECT_FALSE(model.predict(kFrameNs).has_value());  // one pose: no velocity yet
  model.observe({kFrameNs, poseAt(0.01, 0.02), true, false});
  // The step from frame 0 to 1 is poseAt(0.01, 0.02); the next one repeats it.
  const auto next = model.predict(2 * kFrameNs);
  ASSERT_TRUE(next.has_value());
  const Eigen::Isometry3d step = poseAt(0.01, 0.02);
  EXPECT_TRUE(next->isApprox(step * step, 1e-9)) << next->matrix();
  // A dropped frame: two intervals ahead the step is doubled (twice the translation and angle).
  const auto skip = model.predict(3 * kFrameNs);
  ASSERT_TRUE(skip.has_value());
  EXPECT_TRUE(skip->isApprox(step * poseAt(0.02, 0.04), 1e-9)) << skip->matrix();
}

// After a dropped frame the last step spans two intervals: the next frame, one interval on, is
// predicted with half of it, not all of it; and a step that spans a gap from the start is found
// out by the first normal spacing.
TEST(ConstantVelocityModel, AStepOverADroppedFrameIsOneMotionPerInterval) {
  for (const bool turning : {false, true}) {  // a sideways move and a turn on the spot
    auto pose = [&](double k) { return turning ? poseAt(0.0, 0.02 * k) : poseAt(0.01 * k, 0.0); };
    ConstantVelocityModel model;
    model.observe({0, pose(0), true, false});
    model.observe({kFrameNs, pose(1), true, false});
    model.observe({3 * kFrameNs, pose(3), true, false});  // frame 2 dropped
    EXPECT_EQ(model.frameIntervalNs(), kFrameNs);
    EXPECT_DOUBLE_EQ(model.stepIntervals(), 2.0);
    const auto next = model.predict(4 * kFrameNs);
    ASSERT_TRUE(next.has_value());
    EXPECT_TRUE(next->isApprox(pose(4), 1e-9)) << next->matrix();
    // The turn per frame interval is the step's over its two intervals: 0.02 rad per frame.
    ASSERT_TRUE(model.turnPerIntervalDeg().has_value());
    EXPECT_NEAR(*model.turnPerIntervalDeg(), turning ? 0.02 * 180.0 / M_PI : 0.0, 1e-9);
  }
  EXPECT_FALSE(ConstantVelocityModel().turnPerIntervalDeg().has_value());  // no velocity, no turn

  ConstantVelocityModel gap_first;
  gap_first.observe({0, poseAt(0.0, 0.0), true, false});
  gap_first.observe({2 * kFrameNs, poseAt(0.02, 0.0), true, false});  // frame 1 dropped
  gap_first.observe({3 * kFrameNs, poseAt(0.03, 0.0), true, false});
  EXPECT_EQ(gap_first.frameIntervalNs(), kFrameNs);
  const auto after = gap_first.predict(4 * kFrameNs);
  ASSERT_TRUE(after.has_value());
  EXPECT_NEAR(after->translation().x(), 0.04, 1e-9);
  // Jitter of a few ms does not scale the prediction.
  EXPECT_NEAR(gap_first.predict(4 * kFrameNs + 4'000'000)->translation().x(), 0.04, 1e-9);
}

TEST(ConstantVelocityModel, ResetRules) {
  ConstantVelocityModel model(1.0);
  model.observe({0, poseAt(0.0, 0.0), true, false});
  model.observe({kFrameNs, poseAt(0.01, 0.0), true, false});
  ASSERT_TRUE(model.hasVelocity());
  // A jump (loop closure, relocalisation): the new pose is kept, no velocity across the jump.
  model.observe({2 * kFrameNs, poseAt(5.0, 0.0), true, true});
  EXPECT_FALSE(model.hasVelocity());
  EXPECT_FALSE(model.predict(3 * kFrameNs).has_value());
  ASSERT_TRUE(model.last().has_value());
  EXPECT_NEAR(model.last()->translation().x(), 5.0, 1e-12);
  model.observe({3 * kFrameNs, poseAt(5.01, 0.0), true, false});
  EXPECT_TRUE(model.hasVelocity());
  // Lost: everything is forgotten.
  model.observe({4 * kFrameNs, poseAt(0.0, 0.0), false, false});
  EXPECT_FALSE(model.last().has_value());
  // Time going backwards starts over from that pose.
  model.observe({10 * kFrameNs, poseAt(1.0, 0.0), true, false});
  model.observe({11 * kFrameNs, poseAt(1.01, 0.0), true, false});
  model.observe({5 * kFrameNs, poseAt(2.0, 0.0), true, false});
  EXPECT_FALSE(model.hasVelocity());
  // A gap over max_gap_s is a jump.
  model.observe({5 * kFrameNs + 2'000'000'000, poseAt(2.01, 0.0), true, false});
  EXPECT_FALSE(model.hasVelocity());
}

// A correction of the earlier poses (a local BA applied late) is applied to the last pose before
// the step is formed: the velocity stays the camera's motion, not the correction.
TEST(ConstantVelocityModel, CorrectionOfTheEarlierPosesIsNotMotion) {
  ConstantVelocityModel model;
  model.observe({0, poseAt(0.0, 0.0), true, false});
  model.observe({kFrameNs, poseAt(0.01, 0.0), true, false});
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  correction.translation() << 0.0, 0.05, 0.0;  // the world moved 5 cm under frames 0 and 1
  PoseUpdate update{2 * kFrameNs, correction * poseAt(0.02, 0.0), true, false};
  update.T_correction = correction;
  model.observe(update);
  ASSERT_TRUE(model.lastStep().has_value());
  EXPECT_TRUE(model.lastStep()->isApprox(poseAt(0.01, 0.0), 1e-9)) << model.lastStep()->matrix();
  // Without it, the 5 cm would have become velocity.
  ConstantVelocityModel uncorrected;
  uncorrected.observe({0, poseAt(0.0, 0.0), true, false});
  uncorrected.observe({kFrameNs, poseAt(0.01, 0.0), true, false});
  uncorrected.observe({2 * kFrameNs, correction * poseAt(0.02, 0.0), true, false});
  EXPECT_GT((uncorrected.lastStep()->translation() - poseAt(0.01, 0.0).translation()).norm(), 0.04);
}

}  // namespace DYPHO_UNITY_ID
