/// A missing frame costs nothing: fast hand-held turns (the generator's fast-rpy motion) tracked
/// whole, with every 15th frame removed, and with 10 % removed at random, as a loaded live graph
/// or an unreadable file removes them.
#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/tools/synthetic_scene.h"
#include "dypho/tracking/rgbd_odometry.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

class MissingFrames : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tools::SynthOptions o;
    o.frames = 150;  // 5 s: the turn reaches full speed (about 100 deg/s) after 2 s
    o.motion = tools::SynthMotion::kFastRpy;
    o.people = 0;
    const tools::SyntheticScene scene(o);
    for (int i = 0; i < o.frames; ++i) frames_.push_back(scene.render(i));
  }
  static void TearDownTestSuite() { frames_.clear(); }

  /// Position RMSE [m] of the frames tracked (those `keep` says), against the ground truth in the
  /// first camera's frame (the tracker's world).
  static double trackedRmseM(const std::vector<bool>& keep) {
    RgbdOdometry odometry{TrackingOptions()};
    const Eigen::Isometry3d T_camera0_world = frames_[0].T_world_camera.inverse();
    double sum_sq = 0.0;
    int count = 0;
    for (std::size_t i = 0; i < frames_.size(); ++i) {
      if (!keep[i]) continue;
      const TrackingResult r = odometry.track(frames_[i].frame, cv::Mat());
      EXPECT_EQ(r.state, TrackingState::kOk) << "frame " << i << ": " << r.message;
      const Eigen::Vector3d truth = (T_camera0_world * frames_[i].T_world_camera).translation();
      sum_sq += (r.T_world_camera.translation() - truth).squaredNorm();
      ++count;
    }
    return std::sqrt(sum_sq / count);
  }

  static std::vector<tools::SynthFrame> frames_;
};

std::vector<tools::SynthFrame> MissingFrames::frames_;

TEST_F(MissingFrames, DroppedFramesDoNotMoveTheTrajectory) {
  const std::size_t n = frames_.size();
  std::vector<bool> whole(n, true), every15(n, true), random10(n, true);
  for (std::size_t i = 14; i < n; i += 15) every15[i] = false;
  std::mt19937 rng(7);
  std::bernoulli_distribution drop(0.1);
  for (std::size_t i = 1; i < n; ++i) random10[i] = !drop(rng);
  const double whole_m = trackedRmseM(whole);
  const double every15_m = trackedRmseM(every15);
  const double random10_m = trackedRmseM(random10);
  std::cout << "tracked RMSE: whole " << 100.0 * whole_m << " cm, every 15th dropped " << 100.0 * every15_m
            << " cm, 10 % at random " << 100.0 * random10_m << " cm\n";
  // The tracker alone, frame poses as published, no alignment: 0.53 cm measured (the turn at full
  // speed drifts a little); 2 cm bounds a tracker that loses the turn.
  EXPECT_LT(whole_m, 0.02);
  // Every 15th frame dropped: the bound, within 10 % (plus 1 mm for the frames that are
  // not there to be averaged); measured 0.55 cm against 0.53 cm (0.60 before the blur weights).
  // (The runner on the 300-frame version of this motion, before the motion model counted frame
  // intervals: +74 % ATE.)
  EXPECT_LT(every15_m, 1.10 * whole_m + 0.001) << "whole " << whole_m << " m";
  // 10 % at random, sometimes two in a row: within 25 % (plus 1 mm); measured 0.49 cm.
  EXPECT_LT(random10_m, 1.25 * whole_m + 0.001) << "whole " << whole_m << " m";
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
