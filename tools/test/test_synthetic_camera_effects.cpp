// Unit tests of the synthetic colour camera's effects: motion blur (SynthOptions::exposure_s) and
// rolling shutter (SynthOptions::rolling_shutter_s). Small images (320 x 240) keep them fast.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "dypho/tools/synthetic_scene.h"

using dypho::tools::SyntheticScene;
using dypho::tools::SynthFrame;
using dypho::tools::SynthMotion;
using dypho::tools::SynthOptions;

namespace DYPHO_UNITY_ID {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

/// Half the default camera: 320 x 240, fx = fy = 262.5.
dypho::CameraIntrinsics halfCamera() {
  dypho::CameraIntrinsics c = dypho::tools::defaultSynthCamera();
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 262.5;
  c.cx = 159.5;
  c.cy = 119.5;
  return c;
}

/// Fast turns, no people, exact depth, the small camera; effects as given.
SynthOptions fastTurnOptions(double exposure_s, double rolling_shutter_s) {
  SynthOptions o;
  o.motion = SynthMotion::kFastRpy;
  o.frames = 150;
  o.people = 0;
  o.depth_noise = false;
  o.camera = halfCamera();
  o.exposure_s = exposure_s;
  o.rolling_shutter_s = rolling_shutter_s;
  return o;
}

/// Angular velocity [rad/s] of the camera in its own frame at `t_s` (central difference, 1 ms).
Eigen::Vector3d angularVelocity(const SyntheticScene& scene, double t_s) {
  const double dt = 1e-3;
  const Eigen::Matrix3d dR =
      scene.cameraPoseAtTime(t_s - dt).linear().transpose() * scene.cameraPoseAtTime(t_s + dt).linear();
  const Eigen::AngleAxisd aa(dR);
  return aa.axis() * aa.angle() / (2 * dt);
}

/// The frame of `scene` (from frame 60 on: past the start-up envelope) whose camera turns fastest
/// about the given camera axis (0 = x, 1 = y, -1 = any).
int fastestFrame(const SyntheticScene& scene, int axis) {
  int best = 60;
  double best_rate = -1.0;
  for (int i = 60; i < scene.numFrames(); ++i) {
    const Eigen::Vector3d w = angularVelocity(scene, i / scene.options().fps);
    const double rate = axis < 0 ? w.norm() : std::abs(w[axis]);
    if (rate > best_rate) {
      best_rate = rate;
      best = i;
    }
  }
  return best;
}

cv::Mat gray(const SynthFrame& f) {
  cv::Mat g;
  cv::cvtColor(f.frame.bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

double meanGradient(const cv::Mat& gray8) {
  cv::Mat gx, gy, mag;
  cv::Sobel(gray8, gx, CV_32F, 1, 0);
  cv::Sobel(gray8, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, mag);
  return cv::mean(mag)[0];
}

bool sameImage(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF) == 0.0; }

// Off by default: exposure 0 and readout 0 are the defaults, and setting them explicitly gives
// the very same images (bit for bit) as a default SynthOptions. That the default images are the
// ones of earlier versions is checked by SynthPeople.DefaultFramesAreBitIdenticalToBefore
// (checksums recorded before these effects existed).
TEST(SynthCameraEffects, OffByDefaultAndZeroIsTheDefaultRender) {
  const SynthOptions defaults;
  EXPECT_EQ(defaults.exposure_s, 0.0);
  EXPECT_EQ(defaults.rolling_shutter_s, 0.0);
  SynthOptions o = fastTurnOptions(0.0, 0.0);
  o.people = 2;
  o.depth_noise = true;
  SynthOptions implicit_zero = o;
  implicit_zero.exposure_s = defaults.exposure_s;
  implicit_zero.rolling_shutter_s = defaults.rolling_shutter_s;
  const SyntheticScene a(o), b(implicit_zero);
  const SynthFrame fa = a.render(90), fb = b.render(90);
  EXPECT_TRUE(sameImage(fa.frame.bgr, fb.frame.bgr));
  EXPECT_TRUE(sameImage(fa.frame.depth_m, fb.frame.depth_m));
  EXPECT_TRUE(sameImage(fa.mask_gt, fb.mask_gt));
  for (int row : {0, 120, 239}) EXPECT_EQ(a.rowTimeOffsetS(row), 0.0);
}

// A fast turn blurs the colour image: 15 ms of the fastest turn of the sequence (about 100 deg/s,
// 1.5 deg or 7 px at this focal length) averages 7-8 renders. Measured: the mean Sobel gradient
// magnitude drops to about 0.6 of the sharp image's; the bound 0.8 leaves room for other textures
// and seeds, and a blur that did nothing (ratio 1) or only shifted the image fails it. The mean
// brightness stays (an average of the same surfaces): within 2 grey levels. Depth, masks and pose
// are the sharp frame-time ones.
TEST(SynthCameraEffects, MotionBlurSmoothsAFastTurn) {
  const SyntheticScene sharp_scene(fastTurnOptions(0.0, 0.0));
  const SyntheticScene blur_scene(fastTurnOptions(0.015, 0.0));
  const int index = fastestFrame(sharp_scene, -1);
  const double rate_degs = angularVelocity(sharp_scene, index / 30.0).norm() * kRadToDeg;
  const SynthFrame sharp = sharp_scene.render(index), blurred = blur_scene.render(index);
  const double g_sharp = meanGradient(gray(sharp)), g_blur = meanGradient(gray(blurred));
  std::printf("frame %d, %.1f deg/s: mean gradient sharp %.2f, blurred %.2f (ratio %.3f)\n", index, rate_degs, g_sharp,
              g_blur, g_blur / g_sharp);
  EXPECT_GT(rate_degs, 80.0) << "the test needs a fast turn";
  EXPECT_LT(g_blur, 0.8 * g_sharp);
  EXPECT_NEAR(cv::mean(gray(blurred))[0], cv::mean(gray(sharp))[0], 2.0);
  EXPECT_TRUE(sameImage(sharp.frame.depth_m, blurred.frame.depth_m));
  EXPECT_TRUE(sameImage(sharp.static_depth_m, blurred.static_depth_m));
  EXPECT_TRUE(sharp.T_world_camera.isApprox(blurred.T_world_camera, 0.0));
}

// A still camera moves the image by far less than a pixel during 15 ms: one render, the sharp
// image exactly. With walking people only they blur: the background more than 12 px away from any
// person (their motion in 15 ms at <= 1.4 m/s is under 10 px here) keeps its colour; the
// camera's sub-millimetre jitter inside the exposure may change a grey level at a few edges, so
// the bound is a mean absolute difference of 0.5 grey levels.
TEST(SynthCameraEffects, StillCameraStaysSharp) {
  for (int people : {0, 3}) {
    SynthOptions o = fastTurnOptions(0.0, 0.0);
    o.motion = SynthMotion::kStatic;
    o.people = people;
    SynthOptions ob = o;
    ob.exposure_s = 0.015;
    const SynthFrame sharp = SyntheticScene(o).render(40), blurred = SyntheticScene(ob).render(40);
    if (people == 0) {
      EXPECT_TRUE(sameImage(sharp.frame.bgr, blurred.frame.bgr));
      continue;
    }
    cv::Mat near_people;
    cv::dilate(sharp.mask_gt | blurred.mask_gt, near_people, cv::Mat(), cv::Point(-1, -1), 12);
    ASSERT_GT(cv::countNonZero(sharp.mask_gt), 500) << "the check needs people in view";
    cv::Mat diff;
    cv::absdiff(gray(sharp), gray(blurred), diff);
    const double background_diff = cv::mean(diff, near_people == 0)[0];
    const double people_diff = cv::mean(diff, sharp.mask_gt)[0];
    std::printf("still camera, 3 people: mean |diff| background %.3f, people %.3f\n", background_diff, people_diff);
    EXPECT_LT(background_diff, 0.5);
    EXPECT_GT(people_diff, 1.0) << "walking people must blur";
  }
}

// Rolling shutter: row r is seen (r + 0.5) / rows - 0.5 readouts after the stamp. Between the
// global-shutter and the rolling-shutter image of one frame, a band of rows near the top is
// shifted one way and a band near the bottom the other way, by the image motion of the camera
// over the band's time offset. Measured by phase correlation on two 32 x 192 px bands (rows
// centred 48 and 192, i.e. -0.3 and +0.3 readouts = -9 and +9 ms) at the frame whose camera yaws
// fastest (about 95 deg/s: +-4 px, 7.7 px apart); predicted (a) from the poses at the bands' times
// (projecting the frame-time depth of sample pixels; the camera only rotates, apart from mm of
// tremor) and (b) from the angular velocity alone: du = -fx w_y dt, dv = +fy w_x dt. Measured
// errors were <= 0.25 px (the shear inside a band, 1.5 px over 32 rows, smears the correlation
// peak: taller bands bias it towards zero). Tolerance: 0.6 px for (a), 0.6 px + 10 % for (b)
// (the rate changes a little over 18 ms and the off-centre perspective adds a few percent).
TEST(SynthCameraEffects, RollingShutterShearsAYawTurnByRateTimesReadout) {
  const double readout_s = 0.030;
  const SyntheticScene global(fastTurnOptions(0.0, 0.0));
  const SyntheticScene rolling(fastTurnOptions(0.0, readout_s));
  const int index = fastestFrame(global, 1);
  const double t_s = index / 30.0;
  const SynthFrame gs = global.render(index), rs = rolling.render(index);
  EXPECT_TRUE(sameImage(gs.frame.depth_m, rs.frame.depth_m)) << "depth is global-shutter-like";
  EXPECT_TRUE(gs.T_world_camera.isApprox(rs.T_world_camera, 0.0)) << "ground truth at the stamp";
  const dypho::CameraIntrinsics cam = halfCamera();
  const Eigen::Vector3d w = angularVelocity(global, t_s);
  std::printf("frame %d: camera rates x %.1f y %.1f z %.1f deg/s\n", index, w.x() * kRadToDeg, w.y() * kRadToDeg,
              w.z() * kRadToDeg);
  ASSERT_GT(std::abs(w.y()) * kRadToDeg, 70.0) << "the test needs a fast yaw";
  cv::Mat g_gs, g_rs;
  gray(gs).convertTo(g_gs, CV_64F);
  gray(rs).convertTo(g_rs, CV_64F);
  Eigen::Vector2d measured[2];
  for (int b = 0; b < 2; ++b) {
    const int centre_row = b == 0 ? 48 : 192;
    const cv::Rect band(64, centre_row - 16, 192, 32);
    cv::Mat window;
    cv::createHanningWindow(window, band.size(), CV_64F);
    const cv::Point2d shift = cv::phaseCorrelate(g_gs(band), g_rs(band), window);
    measured[b] = Eigen::Vector2d(shift.x, shift.y);
    // (a) Mean image motion of the band's pixels from the stamp to the band's time.
    const double dt = rolling.rowTimeOffsetS(centre_row);
    const Eigen::Isometry3d T_rs_gs = rolling.cameraPoseAtTime(t_s + dt).inverse() * global.cameraPoseAtTime(t_s);
    Eigen::Vector2d predicted(0, 0);
    int n = 0;
    for (int v = band.y; v < band.y + band.height; v += 8) {
      for (int u = band.x; u < band.x + band.width; u += 8) {
        const double z = gs.frame.depth_m.at<float>(v, u);
        const Eigen::Vector3d p = T_rs_gs * Eigen::Vector3d((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z);
        predicted += Eigen::Vector2d(cam.fx * p.x() / p.z() + cam.cx - u, cam.fy * p.y() / p.z() + cam.cy - v);
        ++n;
      }
    }
    predicted /= n;
    std::printf("band at row %d (%+.1f ms): shift measured (%+.2f, %+.2f) px, predicted (%+.2f, %+.2f) px\n",
                centre_row, 1000 * dt, shift.x, shift.y, predicted.x(), predicted.y());
    EXPECT_NEAR(shift.x, predicted.x(), 0.6) << "band " << b;
    EXPECT_NEAR(shift.y, predicted.y(), 0.6) << "band " << b;
  }
  // (b) Bottom minus top: rate times the readout between the two bands.
  const double dt_bands = rolling.rowTimeOffsetS(192) - rolling.rowTimeOffsetS(48);
  EXPECT_NEAR(dt_bands, 0.6 * readout_s, 1e-12);
  const Eigen::Vector2d expected(-cam.fx * w.y() * dt_bands, cam.fy * w.x() * dt_bands);
  const Eigen::Vector2d got = measured[1] - measured[0];
  std::printf("bottom - top: measured (%+.2f, %+.2f) px, rate x readout (%+.2f, %+.2f) px\n", got.x(), got.y(),
              expected.x(), expected.y());
  EXPECT_GT(std::abs(got.x()), 5.0) << "the shear must be clearly visible";
  EXPECT_NEAR(got.x(), expected.x(), 0.6 + 0.1 * std::abs(expected.x()));
  EXPECT_NEAR(got.y(), expected.y(), 0.6 + 0.1 * std::abs(expected.y()));
}

// The presets of dypho_synth --hard-case kinect-fast in one render: blur and rolling shutter
// together, people and depth noise on. Everything but the colour is the frame-time render.
TEST(SynthCameraEffects, BlurAndRollingShutterTogetherKeepDepthAndMasks) {
  SynthOptions o = fastTurnOptions(0.0, 0.0);
  o.people = 2;
  o.depth_noise = true;
  SynthOptions oe = o;
  oe.exposure_s = 0.015;
  oe.rolling_shutter_s = 0.030;
  const SyntheticScene plain(o), effects(oe);
  const SynthFrame a = plain.render(100), b = effects.render(100);
  EXPECT_TRUE(sameImage(a.frame.depth_m, b.frame.depth_m));
  EXPECT_TRUE(sameImage(a.mask_gt, b.mask_gt));
  EXPECT_TRUE(sameImage(a.person_id_gt, b.person_id_gt));
  EXPECT_FALSE(sameImage(a.frame.bgr, b.frame.bgr));
  EXPECT_NEAR(effects.rowTimeOffsetS(0), -0.5 * 0.030 + 0.5 * 0.030 / 240, 1e-12);
  EXPECT_NEAR(effects.rowTimeOffsetS(239), 0.5 * 0.030 - 0.5 * 0.030 / 240, 1e-12);
}

TEST(SynthCameraEffects, RejectsDurationsOutsideOneFrame) {
  SynthOptions o;
  o.exposure_s = -0.001;
  EXPECT_THROW(o.validate(), std::runtime_error);
  o = SynthOptions{};
  o.rolling_shutter_s = 0.05;  // > 1/30 s
  try {
    o.validate();
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("rolling_shutter_s"), std::string::npos) << e.what();
  }
  o = SynthOptions{};
  o.exposure_s = std::nan("");
  EXPECT_THROW(o.validate(), std::runtime_error);
  o = SynthOptions{};
  o.exposure_s = 1.0 / 30.0;
  o.rolling_shutter_s = 1.0 / 30.0;
  EXPECT_NO_THROW(o.validate());
  EXPECT_NE(o.toString().find("exposure_s="), std::string::npos);
  EXPECT_NE(o.toString().find("rolling_shutter_s="), std::string::npos);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
