// Unit tests of the synthetic camera trajectories: smoothness, speed bounds, loop closure.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "dypho/tools/synthetic_scene.h"

using dypho::tools::SyntheticScene;
using dypho::tools::SynthMotion;
using dypho::tools::SynthOptions;

namespace DYPHO_UNITY_ID {

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

// fast-rpy (SynthMotion::kFastRpy): fast hand-held turns like TUM fr1/rpy. Sampled every 2 ms
// over 20 s for two seeds. Bounds: the peak rate is 90-120 deg/s (the three sinusoids peak at 85,
// 50 and 48 deg/s; they line up to about 110 deg/s at most); smooth: the angular acceleration
// stays under 600 deg/s^2 (sum of the three sinusoids' 266 + 126 + 106 deg/s^2 plus the coupling
// of the Euler angles) while a jump of 0.1 deg between two 2 ms samples would already be
// 25000 deg/s^2; the position stays within 11 mm of the start (twice the tremor's largest offset
// sqrt(3) * 3 mm), moves (> 1 mm: the tremor is there) and depends on the seed; starts at rest.
TEST(SynthFastRpy, TurnsFastAndSmoothlyAboutAFixedPoint) {
  Eigen::Vector3d first_positions[2];
  for (std::uint32_t seed : {1u, 2u}) {
    SynthOptions o;
    o.motion = SynthMotion::kFastRpy;
    o.frames = 600;
    o.seed = seed;
    const SyntheticScene scene(o);
    const double dt = 0.002;
    const Eigen::Vector3d home = scene.cameraPoseAtTime(0.0).translation();
    double peak_rate = 0, peak_ang_acc = 0, peak_acc = 0, max_offset = 0, mean_rate = 0;
    Eigen::Vector3d prev_w = Eigen::Vector3d::Zero();
    const int n = static_cast<int>(20.0 / dt);
    for (int i = 0; i < n; ++i) {
      const Eigen::Isometry3d a = scene.cameraPoseAtTime(i * dt), b = scene.cameraPoseAtTime((i + 1) * dt);
      const Eigen::AngleAxisd aa(a.linear().transpose() * b.linear());
      const Eigen::Vector3d w = aa.axis() * aa.angle() * kRadToDeg / dt;  // camera frame [deg/s]
      peak_rate = std::max(peak_rate, w.norm());
      mean_rate += w.norm() / n;
      if (i > 0) peak_ang_acc = std::max(peak_ang_acc, (w - prev_w).norm() / dt);
      prev_w = w;
      const Eigen::Vector3d acc =
          (scene.cameraPoseAtTime((i + 2) * dt).translation() - 2 * b.translation() + a.translation()) / (dt * dt);
      peak_acc = std::max(peak_acc, acc.norm());
      max_offset = std::max(max_offset, (a.translation() - home).norm());
    }
    const MotionStats frames = measure(scene);
    std::printf(
        "fast-rpy seed %u: peak %.1f deg/s (frames: %.1f), mean %.1f deg/s, max %.0f deg/s^2, %.2f m/s^2, "
        "offset %.2f mm, max rotation %.1f deg\n",
        seed, peak_rate, frames.max_rate_degs, mean_rate, peak_ang_acc, peak_acc, 1000 * max_offset,
        frames.max_rotation_from_start_deg);
    EXPECT_GE(peak_rate, 90.0);
    EXPECT_LE(peak_rate, 120.0);
    EXPECT_GE(frames.max_rate_degs, 85.0) << "30 fps frame to frame";
    EXPECT_LE(peak_ang_acc, 600.0);
    EXPECT_LE(peak_acc, 3.0) << "hand tremor of a few mm";
    EXPECT_LE(max_offset, 0.011);
    EXPECT_GE(max_offset, 0.001);
    EXPECT_LE(frames.max_rotation_from_start_deg, 50.0);
    EXPECT_LT(angleDeg(scene.cameraPose(0).linear().transpose() * scene.cameraPose(1).linear()) * o.fps, 5.0)
        << "starts at rest";
    first_positions[seed - 1] = scene.cameraPoseAtTime(5.0).translation();
  }
  EXPECT_GT((first_positions[0] - first_positions[1]).norm(), 1e-4) << "the tremor's phases come from the seed";
}

// fast-rpy keeps the room in view: every 30th frame of 10 s (noisy depth, 2 people) has valid
// depth on >= 90 % of the pixels (noise holes and dropout take 1-5 %) and sees the room at >= 1 m
// in the image centre (no wall or furniture right in front of the lens).
TEST(SynthFastRpy, EveryFrameSeesTheRoom) {
  SynthOptions o;
  o.motion = SynthMotion::kFastRpy;
  o.frames = 300;
  o.camera.width = 320;
  o.camera.height = 240;
  o.camera.fx = o.camera.fy = 262.5;
  o.camera.cx = 159.5;
  o.camera.cy = 119.5;
  const SyntheticScene scene(o);
  for (int i = 0; i < o.frames; i += 30) {
    const dypho::tools::SynthFrame f = scene.render(i);
    const double valid = cv::countNonZero(f.frame.depth_m > 0.f) / static_cast<double>(f.frame.depth_m.total());
    EXPECT_GE(valid, 0.9) << "frame " << i;
    EXPECT_GE(f.static_depth_m.at<float>(120, 160), 1.0f) << "frame " << i;
  }
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
