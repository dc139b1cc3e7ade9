// Unit tests of the synthetic camera trajectories: smoothness, speed bounds, loop closure.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "dypho/tools/synthetic_scene.h"

using dypho::tools::SyntheticScene;
using dypho::tools::SynthMotion;
using dypho::tools::SynthOptions;

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

double angleDeg(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle() * kRadToDeg; }

struct MotionStats {
  double max_speed_ms = 0, max_rate_degs = 0, max_acc_ms2 = 0, max_ang_acc_degs2 = 0;
  double path_m = 0, max_rotation_from_start_deg = 0, max_offset_from_start_m = 0;
};

MotionStats measure(const SyntheticScene& scene) {
  const double fps = scene.options().fps;
  MotionStats s;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < scene.numFrames(); ++i) poses.push_back(scene.cameraPose(i));
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const Eigen::Vector3d dp = poses[i].translation() - poses[i - 1].translation();
    const double rate = angleDeg(poses[i - 1].linear().transpose() * poses[i].linear()) * fps;
    s.max_speed_ms = std::max(s.max_speed_ms, dp.norm() * fps);
    s.max_rate_degs = std::max(s.max_rate_degs, rate);
    s.path_m += dp.norm();
    s.max_rotation_from_start_deg =
        std::max(s.max_rotation_from_start_deg, angleDeg(poses[0].linear().transpose() * poses[i].linear()));
    s.max_offset_from_start_m =
        std::max(s.max_offset_from_start_m, (poses[i].translation() - poses[0].translation()).norm());
    if (i >= 2) {
      const Eigen::Vector3d acc =
          (poses[i].translation() - 2 * poses[i - 1].translation() + poses[i - 2].translation()) * fps * fps;
      s.max_acc_ms2 = std::max(s.max_acc_ms2, acc.norm());
      const double prev_rate = angleDeg(poses[i - 2].linear().transpose() * poses[i - 1].linear()) * fps;
      s.max_ang_acc_degs2 = std::max(s.max_ang_acc_degs2, std::abs(rate - prev_rate) * fps);
    }
  }
  return s;
}

}  // namespace

class SynthMotionTest : public ::testing::TestWithParam<SynthMotion> {};

TEST_P(SynthMotionTest, IsSmoothAndWithinHandHeldSpeeds) {
  SynthOptions o;
  o.motion = GetParam();
  o.frames = 600;  // 20 s covers every period of the sinusoids at least once
  const SyntheticScene scene(o);
  const MotionStats s = measure(scene);
  std::printf("%s: max %.3f m/s %.1f deg/s, max acc %.3f m/s^2 %.1f deg/s^2, path %.2f m, max rot %.1f deg\n",
              dypho::tools::synthMotionName(o.motion).c_str(), s.max_speed_ms, s.max_rate_degs, s.max_acc_ms2,
              s.max_ang_acc_degs2, s.path_m, s.max_rotation_from_start_deg);
  // TUM hand-held sequences stay under ~0.5 m/s and ~40 deg/s.
  EXPECT_LE(s.max_speed_ms, 0.5);
  EXPECT_LE(s.max_rate_degs, 40.0);
  // Smooth: a 1 cm jump between two frames would already be 9 m/s^2 at 30 fps; sinusoids of
  // these amplitudes and periods stay below 1 m/s^2 and 100 deg/s^2.
  EXPECT_LE(s.max_acc_ms2, 1.0);
  EXPECT_LE(s.max_ang_acc_degs2, 100.0);
  for (int i = 0; i < scene.numFrames(); i += 10) {
    const Eigen::Isometry3d T = scene.cameraPose(i);
    EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-9);
    EXPECT_TRUE((T.linear().transpose() * T.linear()).isIdentity(1e-9));
    // Inside the 7 x 6 x 3 m room with >= 0.3 m to spare.
    EXPECT_LT(std::abs(T.translation().x()), 3.2);
    EXPECT_LT(std::abs(T.translation().y()), 2.7);
    EXPECT_GT(T.translation().z(), 0.3);
    EXPECT_LT(T.translation().z(), 2.7);
  }
  switch (o.motion) {
    case SynthMotion::kStatic:
      EXPECT_LT(s.max_offset_from_start_m, 1e-3);
      EXPECT_LT(s.max_rotation_from_start_deg, 0.05);
      break;
    case SynthMotion::kRpy:
      EXPECT_LT(s.max_offset_from_start_m, 1e-9);  // rotation only
      EXPECT_GT(s.max_rotation_from_start_deg, 15.0);
      break;
    case SynthMotion::kXyz:
      EXPECT_LT(s.max_rotation_from_start_deg, 1e-6);  // translation only
      EXPECT_GT(s.max_offset_from_start_m, 0.3);
      break;
    default:
      EXPECT_GT(s.path_m, 2.0);
      break;
  }
}

INSTANTIATE_TEST_SUITE_P(AllMotions, SynthMotionTest,
                         ::testing::Values(SynthMotion::kXyz, SynthMotion::kHalfsphere, SynthMotion::kStatic,
                                           SynthMotion::kRpy, SynthMotion::kLoop),
                         [](const auto& info) { return dypho::tools::synthMotionName(info.param); });

TEST(SynthLoop, ReturnsToTheStartAfterOneFullTurn) {
  for (int frames : {300, 900}) {
    SynthOptions o;
    o.motion = SynthMotion::kLoop;
    o.frames = frames;
    const SyntheticScene scene(o);
    const Eigen::Isometry3d first = scene.cameraPose(0), last = scene.cameraPose(frames - 1);
    EXPECT_LT((first.translation() - last.translation()).norm(), 1e-9);
    EXPECT_LT(angleDeg(first.linear().transpose() * last.linear()), 1e-6);
    // Half way the camera is on the opposite side of the circle, facing the opposite way.
    const Eigen::Isometry3d mid = scene.cameraPose((frames - 1) / 2);
    const double duration_s = (frames - 1) / o.fps;
    const double radius = std::min(1.5, 0.45 * duration_s / (2 * 3.14159265358979323846));
    EXPECT_NEAR((mid.translation() - first.translation()).norm(), 2 * radius, 0.02);
    EXPECT_GT(angleDeg(first.linear().transpose() * mid.linear()), 170.0);
    EXPECT_NEAR(measure(scene).path_m, 2 * 3.14159265358979323846 * radius, 0.02 * radius);
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
