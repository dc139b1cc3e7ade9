/// compensateRollingShutter on the generator's rolling-shutter images: keypoints of a fast turn
/// moved back to the stamp's camera land where a global shutter sees them.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "dypho/tools/synthetic_scene.h"
#include "dypho/tracking/orb_extractor.h"
#include "dypho/tracking/rolling_shutter.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

FrameFeatures featuresOf(const RgbdFrame& frame, const TrackingOptions& options) {
  cv::Mat gray;
  cv::cvtColor(frame.bgr, gray, cv::COLOR_BGR2GRAY);
  return makeFrameFeatures(OrbExtractor(options).extract(gray, cv::Mat()), frame.depth_m, frame.camera,
                           options.min_depth_m, options.max_depth_m);
}

/// Median distance [px] from each keypoint of `a` to the keypoint of `b` with the nearest
/// descriptor (Hamming <= 40, the match within 30 px).
double medianOffsetPx(const FrameFeatures& a, const FrameFeatures& b) {
  std::vector<double> offsets;
  for (std::size_t i = 0; i < a.size(); ++i) {
    int best = 256;
    double best_px = 0.0;
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double px = (a.uv_undistorted_px[i] - b.uv_undistorted_px[j]).norm();
      if (px > 30.0) continue;
      const int d = static_cast<int>(
          cv::norm(a.descriptors.row(static_cast<int>(i)), b.descriptors.row(static_cast<int>(j)), cv::NORM_HAMMING));
      if (d < best) {
        best = d;
        best_px = px;
      }
    }
    if (best <= 40) offsets.push_back(best_px);
  }
  if (offsets.size() < 50) return -1.0;
  std::nth_element(offsets.begin(), offsets.begin() + static_cast<std::ptrdiff_t>(offsets.size() / 2), offsets.end());
  return offsets[offsets.size() / 2];
}

TEST(RollingShutter, KeypointsOfAFastTurnMoveToTheGlobalShutterView) {
  tools::SynthOptions options;
  options.frames = 60;
  options.motion = tools::SynthMotion::kFastRpy;
  options.people = 0;
  options.depth_noise = false;
  tools::SynthOptions rolling = options;
  rolling.rolling_shutter_s = 0.03;
  const tools::SyntheticScene global_scene(options), rolling_scene(rolling);
  const int frame = 45;  // about 2 s in: turning at full speed
  const double t_s = frame / options.fps, dt_s = 1e-3;
  // The camera's angular velocity in its own frame at the stamp (central difference).
  const Eigen::Matrix3d R_step = (global_scene.cameraPoseAtTime(t_s - dt_s).rotation().transpose() *
                                  global_scene.cameraPoseAtTime(t_s + dt_s).rotation());
  const Eigen::AngleAxisd turn(R_step);
  const Eigen::Vector3d omega_rad_s = turn.axis() * turn.angle() / (2.0 * dt_s);
  ASSERT_GT(omega_rad_s.norm(), 0.8);  // > 45 deg/s: a skew of several pixels over the readout

  const TrackingOptions tracking;
  const RgbdFrame rolling_frame = rolling_scene.render(frame).frame;
  const FrameFeatures global = featuresOf(global_scene.render(frame).frame, tracking);
  const FrameFeatures skewed = featuresOf(rolling_frame, tracking);
  const FrameFeatures compensated =
      compensateRollingShutter(skewed, rolling_frame.depth_m, rolling_frame.camera, omega_rad_s, 0.03);
  const double before_px = medianOffsetPx(skewed, global), after_px = medianOffsetPx(compensated, global);
  ASSERT_GE(before_px, 0.0);
  ASSERT_GE(after_px, 0.0);
  // The skew at this speed is several pixels at the top and bottom rows; compensated, what is left
  // is keypoint detection noise (about a pixel) and the neglected translation.
  EXPECT_GT(before_px, 2.0);
  EXPECT_LT(after_px, 0.5 * before_px);
  EXPECT_LT(after_px, 1.5);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
