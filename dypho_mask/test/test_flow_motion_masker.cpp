#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/mask/flow_motion_masker.h"

namespace dypho {
namespace mask {
namespace DYPHO_UNITY_ID {

const cv::Size kSize(640, 480);

/// Multi-scale random texture (blobs of 64, 24 and 8 px), BGR. Enough structure at the 1/4 flow
/// resolution for dense flow to be well defined everywhere.
cv::Mat makeTexture(const cv::Size& size, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat acc = cv::Mat::zeros(size, CV_32F);
  for (int cell : {64, 24, 8}) {
    cv::Mat coarse(size.height / cell + 2, size.width / cell + 2, CV_32F);
    rng.fill(coarse, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::Mat up;
    cv::resize(coarse, up, size, 0, 0, cv::INTER_CUBIC);
    acc += up;
  }
  cv::Mat grey;
  cv::normalize(acc, acc, 0, 255, cv::NORM_MINMAX);
  acc.convertTo(grey, CV_8U);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

RgbdFrame frameOf(const cv::Mat& bgr) {
  RgbdFrame f;
  f.bgr = bgr;
  return f;
}

/// View of `texture` through a camera rotated by `R_ref_cur` (pure rotation => homography
/// K R K^-1), offset so that the view stays inside the texture.
cv::Mat rotatedView(const cv::Mat& texture, const cv::Matx33d& R_ref_cur) {
  const cv::Matx33d K(525, 0, 319.5, 0, 525, 239.5, 0, 0, 1);
  const double ox = (texture.cols - kSize.width) / 2.0;
  const double oy = (texture.rows - kSize.height) / 2.0;
  const cv::Matx33d T(1, 0, ox, 0, 1, oy, 0, 0, 1);
  const cv::Matx33d M = T * K * R_ref_cur * K.inv();  // current pixel -> texture pixel
  cv::Mat out;
  cv::warpPerspective(texture, out, cv::Mat(M), kSize, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  return out;
}

cv::Matx33d rotation(double rx_deg, double ry_deg, double rz_deg) {
  cv::Mat R;
  cv::Rodrigues(cv::Vec3d(rx_deg, ry_deg, rz_deg) * (CV_PI / 180.0), R);
  return cv::Matx33d(R);
}

/// Background shifted by `bg_shift` (camera motion) with a textured square at `square`.
cv::Mat squareScene(const cv::Mat& background, const cv::Point2d& bg_shift, const cv::Mat& square_texture,
                    const cv::Rect& square) {
  const cv::Matx23d shift(1, 0, bg_shift.x, 0, 1, bg_shift.y);
  cv::Mat frame;
  cv::warpAffine(background, frame, cv::Mat(shift), kSize, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  square_texture(cv::Rect(0, 0, square.width, square.height)).copyTo(frame(square));
  return frame;
}

double iou(const cv::Mat& a, const cv::Mat& b) {
  const double inter = cv::countNonZero(a & b);
  const double uni = cv::countNonZero(a | b);
  return uni > 0 ? inter / uni : 1.0;
}

TEST(FlowMotionMasker, FirstFrameAndIdenticalFramesGiveEmptyMask) {
  FlowMotionMasker masker{FlowMaskOptions()};
  const cv::Mat img = makeTexture(kSize, 1);
  const FlowMaskResult first = masker.compute(frameOf(img));
  EXPECT_FALSE(first.degraded);
  EXPECT_NE(first.message.find("first frame"), std::string::npos) << first.message;
  ASSERT_EQ(first.mask.size(), kSize);
  EXPECT_EQ(cv::countNonZero(first.mask), 0);
  for (int i = 0; i < 3; ++i) {
    const FlowMaskResult r = masker.compute(frameOf(img.clone()));
    EXPECT_FALSE(r.degraded) << r.message;
    ASSERT_EQ(r.mask.size(), kSize);
    ASSERT_EQ(r.mask.type(), CV_8UC1);
    EXPECT_EQ(cv::countNonZero(r.mask), 0);  // exact: zero flow everywhere, no residual
    EXPECT_EQ(r.masked_fraction, 0.0);
    EXPECT_GT(r.inlier_ratio, 0.9);
  }
}

TEST(FlowMotionMasker, PureCameraTranslationIsNotMasked) {
  FlowMotionMasker masker{FlowMaskOptions()};
  const cv::Mat bg = makeTexture(kSize, 2);
  for (int k = 0; k < 6; ++k) {
    const cv::Matx23d shift(1, 0, 5.0 * k, 0, 1, -3.0 * k);
    cv::Mat frame;
    cv::warpAffine(bg, frame, cv::Mat(shift), kSize, cv::INTER_LINEAR, cv::BORDER_REFLECT);
    const FlowMaskResult r = masker.compute(frameOf(frame));
    if (k == 0) continue;
    EXPECT_FALSE(r.degraded) << r.message;
    // Tolerance 2 %: the whole image follows one translation, so only flow errors at the
    // reflected borders (content entering the view) can leave residual regions.
    EXPECT_LT(r.masked_fraction, 0.02) << "frame " << k;
    // The recovered global motion is the translation (flow x_prev = x - (5, -3)), within 0.5 px.
    EXPECT_NEAR(r.H_prev_cur(0, 2), -5.0, 0.5);
    EXPECT_NEAR(r.H_prev_cur(1, 2), 3.0, 0.5);
  }
}

TEST(FlowMotionMasker, PureCameraRotationIsNotMasked) {
  FlowMotionMasker masker{FlowMaskOptions()};
  const cv::Mat texture = makeTexture(cv::Size(1000, 800), 3);
  double max_fraction = 0.0;
  for (int k = 0; k < 6; ++k) {
    // 0.4 deg pitch, 0.8 deg yaw, 0.5 deg roll per frame: up to ~10 px of image motion per frame.
    const cv::Mat frame = rotatedView(texture, rotation(0.4 * k, 0.8 * k, 0.5 * k));
    const FlowMaskResult r = masker.compute(frameOf(frame));
    if (k == 0) continue;
    EXPECT_FALSE(r.degraded) << r.message;
    max_fraction = std::max(max_fraction, r.masked_fraction);
    // 2 %: a rotation is exactly a homography, so residual can only come from flow errors.
    EXPECT_LT(r.masked_fraction, 0.02) << "frame " << k;
  }
  std::printf("[ report ] pure rotation: max masked fraction %.4f\n", max_fraction);
}

/// As `rotatedView`, seen through a camera with radial-tangential distortion: each output pixel is
/// undistorted (`ideal_px`, CV_32FC2 from cv::undistortPoints with P = K), rotated, looked up.
cv::Mat distortedRotatedView(const cv::Mat& texture, const cv::Matx33d& R_ref_cur, const cv::Mat& ideal_px,
                             const cv::Matx33d& K) {
  const cv::Matx33d T(1, 0, (texture.cols - kSize.width) / 2.0, 0, 1, (texture.rows - kSize.height) / 2.0, 0, 0, 1);
  const cv::Matx33d M = T * K * R_ref_cur * K.inv();
  cv::Mat map(kSize, CV_32FC2);
  for (int y = 0; y < kSize.height; ++y) {
    for (int x = 0; x < kSize.width; ++x) {
      const cv::Vec2f p = ideal_px.at<cv::Vec2f>(y, x);
      const cv::Vec3d q = M * cv::Vec3d(p[0], p[1], 1.0);
      map.at<cv::Vec2f>(y, x) = cv::Vec2f(static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2]));
    }
  }
  cv::Mat out;
  cv::remap(texture, out, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return out;
}

TEST(FlowMotionMasker, RotationThroughDistortedLensIsNotMaskedWhenIntrinsicsAreGiven) {
  CameraIntrinsics camera;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.width = kSize.width;
  camera.height = kSize.height;
  // Strong barrel distortion (wide-angle-like; TUM fr1's is too mild to matter at these motions).
  camera.distortion = {{-0.35, 0.12, 0.001, -0.001, 0.0}};
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  std::vector<cv::Point2f> pixels;
  for (int y = 0; y < kSize.height; ++y)
    for (int x = 0; x < kSize.width; ++x) pixels.emplace_back(x, y);
  cv::Mat ideal;
  cv::undistortPoints(pixels, ideal, K, cv::Mat(1, 5, CV_64F, camera.distortion.data()), cv::noArray(), K);
  ideal = ideal.reshape(2, kSize.height);

  const cv::Mat texture = makeTexture(cv::Size(1100, 900), 14);
  FlowMotionMasker with_camera{FlowMaskOptions()};
  FlowMotionMasker without_camera{FlowMaskOptions()};
  double max_with = 0.0, max_without = 0.0;
  for (int k = 0; k < 6; ++k) {
    RgbdFrame f = frameOf(distortedRotatedView(texture, rotation(1.0 * k, 2.5 * k, 1.0 * k), ideal, K));
    const FlowMaskResult raw = without_camera.compute(f);
    f.camera = camera;
    const FlowMaskResult r = with_camera.compute(f);
    if (k == 0) continue;
    EXPECT_FALSE(r.degraded) << r.message;
    // 2 %: in undistorted coordinates the motion is exactly a homography again.
    EXPECT_LT(r.masked_fraction, 0.02) << "frame " << k;
    max_with = std::max(max_with, r.masked_fraction);
    max_without = std::max(max_without, raw.masked_fraction);
  }
  std::printf(
      "[ report ] rotation through a distorted lens: max masked fraction %.4f with "
      "intrinsics, %.4f when the distortion is ignored\n",
      max_with, max_without);
  // The scene is sensitive to the lens: ignoring the distortion leaves visible residual regions
  // (so the check above could fail if the intrinsics were not used).
  EXPECT_GT(max_without, 0.02);
}

TEST(FlowMotionMasker, MovingSquareOverShiftedBackgroundIsMasked) {
  FlowMaskOptions options;
  options.dilate_px = 0;  // measure the detection itself, without the safety margin
  FlowMotionMasker masker(options);
  FlowMotionMasker masker_default{FlowMaskOptions()};
  const cv::Mat bg = makeTexture(kSize, 4);
  const cv::Mat sq = makeTexture(cv::Size(160, 160), 5);
  for (int k = 0; k < 5; ++k) {
    // Camera: background moves (3, 1) px/frame. Object: square moves (8, 5) px/frame in the image,
    // i.e. 6.4 px/frame relative to the background, well above the 2 px threshold.
    const cv::Rect square(200 + 8 * k, 150 + 5 * k, 120, 120);
    const cv::Mat frame = squareScene(bg, cv::Point2d(3.0 * k, 1.0 * k), sq, square);
    const FlowMaskResult r = masker.compute(frameOf(frame));
    const FlowMaskResult rd = masker_default.compute(frameOf(frame));
    if (k == 0) continue;
    ASSERT_FALSE(r.degraded) << r.message;
    ASSERT_FALSE(rd.degraded) << rd.message;
    cv::Mat truth = cv::Mat::zeros(kSize, CV_8UC1);
    truth(square).setTo(255);
    const double overlap = iou(r.mask, truth);
    // IoU >= 0.7: the flow is computed at 1/4 resolution and DIS smooths across the square's
    // border, so the mask edge is uncertain by about one flow pixel (4 px) on each side (a band of
    // ~4*4*120 px = 13 % of the square), and the strip of background uncovered behind the square
    // (up to 8 px wide) has no true correspondence and may be marked too (~7 %).
    EXPECT_GE(overlap, 0.7) << "frame " << k << " masked " << r.masked_fraction;
    // With the default 8 px margin the square must be covered almost entirely (>= 95 %), and
    // nothing far from it may be masked (outside the square grown by 24 px: < 1 % of the image).
    const double covered = static_cast<double>(cv::countNonZero(rd.mask & truth)) / cv::countNonZero(truth);
    EXPECT_GE(covered, 0.95) << "frame " << k;
    cv::Mat near = cv::Mat::zeros(kSize, CV_8UC1);
    near(cv::Rect(square.x - 24, square.y - 24, square.width + 48, square.height + 48)).setTo(255);
    const double far_fraction = static_cast<double>(cv::countNonZero(rd.mask & ~near)) / kSize.area();
    EXPECT_LT(far_fraction, 0.01) << "frame " << k;
    std::printf(
        "[ report ] moving square frame %d: IoU %.3f (no margin), coverage %.3f, "
        "masked %.3f (default options)\n",
        k, overlap, covered, rd.masked_fraction);
  }
}

// Catch-up mode (a live caller fell behind): the flow skips its variational refinement. The
// moving square is still found with the same bound as above (IoU >= 0.7: the refinement only
// polishes the flow inside the DIS patches), and the flow really is another one (the mode is
// not a no-op); switched off again, the flow is the refined one again (less than half the
// catch-up flow's distance from it).
TEST(FlowMotionMasker, CatchUpModeSkipsTheRefinementAndStillFindsTheMover) {
  FlowMaskOptions options;
  options.dilate_px = 0;
  ASSERT_GT(options.dis_refinement_iterations, 0);
  FlowMotionMasker refined(options), catching_up(options), toggled(options);
  catching_up.setCatchingUp(true);
  const cv::Mat bg = makeTexture(kSize, 4);
  const cv::Mat sq = makeTexture(cv::Size(160, 160), 5);
  for (int k = 0; k < 5; ++k) {
    const cv::Rect square(200 + 8 * k, 150 + 5 * k, 120, 120);
    const cv::Mat frame = squareScene(bg, cv::Point2d(3.0 * k, 1.0 * k), sq, square);
    toggled.setCatchingUp(k % 2 == 1);
    const FlowMaskResult r = refined.compute(frameOf(frame));
    const FlowMaskResult c = catching_up.compute(frameOf(frame));
    const FlowMaskResult t = toggled.compute(frameOf(frame));
    if (k == 0) continue;
    ASSERT_FALSE(c.degraded) << c.message;
    cv::Mat truth = cv::Mat::zeros(kSize, CV_8UC1);
    truth(square).setTo(255);
    EXPECT_GE(iou(c.mask, truth), 0.7) << "frame " << k << " masked " << c.masked_fraction;
    EXPECT_GT(cv::norm(refined.lastFlow(), catching_up.lastFlow(), cv::NORM_L1), 0.0) << "frame " << k;
    if (k % 2 == 0) {  // back out of the mode: the refined flow again (DIS keeps some state: not bit-exact)
      EXPECT_LT(cv::norm(refined.lastFlow(), toggled.lastFlow(), cv::NORM_L1),
                0.5 * cv::norm(refined.lastFlow(), catching_up.lastFlow(), cv::NORM_L1))
          << "frame " << k;
    }
  }
}

TEST(FlowMotionMasker, StaticMedianFlowIsTheCameraMotionWhenMoversFillMostOfTheView) {
  // The camera pans (3, 1) px per frame (3.16 px); four textured squares of 200 x 200 px, 52 % of
  // the view together, each move 12 px per frame their own way. Each is smaller than the
  // background, so the ego-motion fit follows the background; the median of all flow lengths is
  // a mover's, the median over the samples the ego-motion explains is the pan's.
  FlowMaskOptions options;
  options.max_masked_fraction = 0.9;  // over half the view moves: not a degraded frame here,
  options.min_inlier_ratio = 0.2;     // and the background's 48 % give 28 % of the fit's samples
  FlowMotionMasker masker(options);
  const cv::Mat bg = makeTexture(kSize, 11);
  const cv::Point origins[4] = {{20, 20}, {420, 20}, {20, 260}, {420, 260}};
  const cv::Point velocities[4] = {{12, 0}, {-12, 0}, {0, 12}, {0, -12}};
  FlowMaskResult r;
  for (int k = 0; k < 2; ++k) {
    const cv::Matx23d shift(1, 0, 3.0 * k, 0, 1, 1.0 * k);
    cv::Mat frame;
    cv::warpAffine(bg, frame, cv::Mat(shift), kSize, cv::INTER_LINEAR, cv::BORDER_REFLECT);
    for (int i = 0; i < 4; ++i) {
      const cv::Mat texture = makeTexture(cv::Size(200, 200), 20 + static_cast<std::uint64_t>(i));
      texture.copyTo(frame(cv::Rect(origins[i] + k * velocities[i], cv::Size(200, 200))));
    }
    r = masker.compute(frameOf(frame));
  }
  ASSERT_FALSE(r.degraded) << r.message << " (masked " << r.masked_fraction << ", inliers " << r.inlier_ratio << ")";
  // 0.5 px: the flow is measured at 1/4 resolution (1 flow px = 4 px) and sub-pixel refined.
  EXPECT_NEAR(r.static_median_flow_px, std::hypot(3.0, 1.0), 0.5);
  EXPECT_GT(r.median_flow_px, 6.0);  // the plain median is a mover's (12 px), not the camera's
  std::printf("[ report ] movers over 52 %%: median flow %.2f px, static median %.2f px\n", r.median_flow_px,
              r.static_median_flow_px);
}

TEST(FlowMotionMasker, TooMuchMaskedWithoutHistoryIsDegradedAndEmpty) {
  FlowMaskOptions options;
  options.max_masked_fraction = 0.01;  // the square alone covers ~5 % of the image
  FlowMotionMasker masker(options);
  const cv::Mat bg = makeTexture(kSize, 6);
  const cv::Mat sq = makeTexture(cv::Size(160, 160), 7);
  masker.compute(frameOf(squareScene(bg, {0, 0}, sq, cv::Rect(200, 150, 120, 120))));
  const FlowMaskResult r = masker.compute(frameOf(squareScene(bg, {0, 0}, sq, cv::Rect(210, 156, 120, 120))));
  EXPECT_TRUE(r.degraded);
  EXPECT_NE(r.message.find("max_masked_fraction"), std::string::npos) << r.message;
  EXPECT_EQ(r.masked_fraction, 0.0);
  EXPECT_EQ(cv::countNonZero(r.mask), 0);
}

TEST(FlowMotionMasker, TooMuchMaskedCarriesThePreviousMaskAlongTheFlow) {
  FlowMaskOptions options;
  options.max_masked_fraction = 0.01;
  FlowMotionMasker masker(options);
  const cv::Mat bg = makeTexture(kSize, 6);
  const cv::Mat sq = makeTexture(cv::Size(160, 160), 7);
  masker.compute(frameOf(squareScene(bg, {0, 0}, sq, cv::Rect(200, 150, 120, 120))));
  cv::Mat previous = cv::Mat::zeros(kSize, CV_8UC1);
  previous(cv::Rect(192, 142, 136, 136)).setTo(255);  // the square with an 8 px margin
  const FlowMaskResult r =
      masker.compute(frameOf(squareScene(bg, {0, 0}, sq, cv::Rect(210, 156, 120, 120))), std::nullopt, previous);
  EXPECT_TRUE(r.degraded);
  EXPECT_NE(r.message.find("carried"), std::string::npos) << r.message;
  // The carried mask lies on the square's new place (shifted by about (10, 6) px), shrunk by the
  // margin: it must cover the square's centre and stay within the old mask moved by the flow.
  cv::Mat expected = cv::Mat::zeros(kSize, CV_8UC1);
  expected(cv::Rect(210, 156, 120, 120)).setTo(255);
  EXPECT_GT(iou(r.mask, expected), 0.75) << "masked fraction " << r.masked_fraction;
  EXPECT_GT(r.masked_fraction, 0.03);
}

/// Crowd: one textured region covering most of the view moves, the camera is still. Without
/// history the fit follows the region (it holds most of the samples); with the previous mask on
/// the region, the fit must be tried again on the rest and mask the region, not the room.
TEST(FlowMotionMasker, PreviousMaskStopsTheFitFromFollowingACrowd) {
  FlowMotionMasker masker{FlowMaskOptions()};
  const cv::Mat bg = makeTexture(kSize, 21);
  const cv::Mat crowd = makeTexture(cv::Size(520, 480), 22);
  const cv::Rect before(20, 0, 440, 480), after(28, 0, 440, 480);  // 69 % of the image, 8 px step
  masker.compute(frameOf(squareScene(bg, {0, 0}, crowd, before)));
  cv::Mat previous = cv::Mat::zeros(kSize, CV_8UC1);
  previous(cv::Rect(12, 0, 456, 480)).setTo(255);
  const FlowMaskResult r = masker.compute(frameOf(squareScene(bg, {0, 0}, crowd, after)), std::nullopt, previous);
  EXPECT_TRUE(r.fit_excluded_previous_mask) << r.message;
  cv::Mat truth = cv::Mat::zeros(kSize, CV_8UC1);
  truth(after).setTo(255);
  // Static room pixels (away from the crowd's edges by more than the margin) must stay static.
  cv::Mat room = cv::Mat::zeros(kSize, CV_8UC1);
  room(cv::Rect(490, 0, 150, 480)).setTo(255);
  EXPECT_LT(cv::countNonZero(r.mask & room), 0.02 * cv::countNonZero(room));
  // The crowd is masked (the mask may exceed max_masked_fraction and then be the carried one;
  // both lie on the crowd).
  EXPECT_GT(static_cast<double>(cv::countNonZero(r.mask & truth)) / cv::countNonZero(truth), 0.9);
}

/// Two people walking apart in front of a still camera: the left one (41 % of the view) moves
/// right, the right one (28 %) left, the room (31 %) between them is still. The previous mask
/// covers the right person and part of the left one. The fit on every sample follows the left
/// person (the largest single motion), and the carried mask does not show it (that fit explains
/// a similar share inside and outside the carried pixels: 36 % and 44 %), so followsCarried()
/// alone keeps it and masks the room. The fit without the carried pixels explains clearly more
/// of the pixels outside them (the room, 56 %, against the left person's uncarried part, 44 %)
/// and must replace it.
TEST(FlowMotionMasker, FitWithoutThePreviousMaskWinsWhenItExplainsMoreOfTheRest) {
  const cv::Mat room = makeTexture(kSize, 31);
  const cv::Mat left = makeTexture(cv::Size(280, 480), 32), right = makeTexture(cv::Size(200, 480), 33);
  const auto scene = [&](int step_px) {
    cv::Mat frame = room.clone();
    left(cv::Rect(8 - step_px, 0, 260, 480)).copyTo(frame(cv::Rect(0, 0, 260, 480)));
    right(cv::Rect(8 + step_px, 0, 180, 480)).copyTo(frame(cv::Rect(460, 0, 180, 480)));
    return frame;
  };
  cv::Mat previous = cv::Mat::zeros(kSize, CV_8UC1);
  previous(cv::Rect(0, 0, 100, 480)).setTo(255);
  previous(cv::Rect(452, 0, 188, 480)).setTo(255);
  cv::Mat room_inner = cv::Mat::zeros(kSize, CV_8UC1);
  room_inner(cv::Rect(292, 0, 136, 480)).setTo(255);  // the room away from the people's edges
  cv::Mat people_inner = cv::Mat::zeros(kSize, CV_8UC1);
  people_inner(cv::Rect(32, 0, 196, 480)).setTo(255);
  people_inner(cv::Rect(492, 0, 116, 480)).setTo(255);
  for (const double margin : {0.05, 0.0}) {
    FlowMaskOptions options;
    options.refit_without_previous_margin = margin;
    options.max_masked_fraction = 0.95;  // people fill 70 % of the view: the fit is under test, not that guard
    FlowMotionMasker masker(options);
    masker.compute(frameOf(scene(0)));
    const FlowMaskResult r = masker.compute(frameOf(scene(8)), std::nullopt, previous);
    ASSERT_FALSE(r.degraded) << r.message;
    const double room_masked =
        static_cast<double>(cv::countNonZero(r.mask & room_inner)) / cv::countNonZero(room_inner);
    std::printf("[ report ] two people apart, refit_without_previous_margin %.2f: room masked %.3f, refit %d\n", margin,
                room_masked, static_cast<int>(r.fit_excluded_previous_mask));
    if (margin > 0.0) {
      EXPECT_TRUE(r.fit_excluded_previous_mask);
      EXPECT_LT(room_masked, 0.02);  // the still room stays static (flow noise: a few pixels)
      const double people_masked =
          static_cast<double>(cv::countNonZero(r.mask & people_inner)) / cv::countNonZero(people_inner);
      EXPECT_GT(people_masked, 0.9);  // both people found (untextured flow pixels are never masked)
    } else {
      // The scene must really need the second fit: without it the room is masked.
      EXPECT_GT(room_masked, 0.5);
    }
  }
}

// A person who moves slowly (1 px per frame, under the 2 px threshold frame to frame) in front
// of a still camera: frame to frame the residual never reaches the threshold; the residual
// memory (0.7) carries it along the flow and adds it up to 1 / (1 - 0.7) = 3.3 px, so after a
// few frames (1 + 0.7 + 0.49 + 0.34 = 2.5 px after 4) the person is masked. Only pixels whose
// residual reaches the sustainable level (1 - 0.7) * 2 px = 0.6 px keep their memory; DIS at the
// 1/4 flow resolution measures the quarter-pixel step short on part of the square (its weakly
// textured spots, the border band of one flow pixel), and those pixels start afresh.
TEST(FlowMotionMasker, ResidualMemoryFindsASlowMover) {
  FlowMaskOptions frame_to_frame;
  frame_to_frame.residual_memory = 0.0;
  FlowMotionMasker with_memory{FlowMaskOptions()}, without_memory(frame_to_frame);
  ASSERT_GT(FlowMaskOptions().residual_memory, 0.0);
  const cv::Mat bg = makeTexture(kSize, 31);
  const cv::Mat person = makeTexture(cv::Size(160, 160), 32);
  for (int k = 0; k < 10; ++k) {
    const cv::Rect square(200 + k, 160, 140, 140);
    const cv::Mat frame = squareScene(bg, {0, 0}, person, square);
    const FlowMaskResult r = with_memory.compute(frameOf(frame));
    const FlowMaskResult r0 = without_memory.compute(frameOf(frame));
    if (k == 0) continue;
    ASSERT_FALSE(r.degraded) << r.message;
    ASSERT_FALSE(r0.degraded) << r0.message;
    cv::Mat truth = cv::Mat::zeros(kSize, CV_8UC1);
    truth(square).setTo(255);
    const double covered = static_cast<double>(cv::countNonZero(r.mask & truth)) / square.area();
    const double covered0 = static_cast<double>(cv::countNonZero(r0.mask & truth)) / square.area();
    std::printf("[ report ] slow mover frame %d: covered %.3f with memory, %.3f without\n", k, covered, covered0);
    // Without memory: at most 10 % (flow noise at the square's edges can pass 2 px here and there).
    EXPECT_LT(covered0, 0.1) << "frame " << k;
    // With memory, from the 8th residual on (the ideal sum is then within 6 % of 3.3 px): the
    // greater part of the square (>= 60 %; measured 73 %, see above for what is missed), where
    // frame to frame finds nothing.
    if (k >= 8) {
      EXPECT_GE(covered, 0.6) << "frame " << k;
    }
    // Nothing far from the person is masked (< 1 % of the image outside the square + 24 px).
    cv::Mat near = cv::Mat::zeros(kSize, CV_8UC1);
    near(cv::Rect(square.x - 24, square.y - 24, square.width + 48, square.height + 48)).setTo(255);
    EXPECT_LT(static_cast<double>(cv::countNonZero(r.mask & ~near)) / kSize.area(), 0.01) << "frame " << k;
  }
}

// The memory would add up the ego-motion model's repeated errors, which grow with the camera's
// image motion: while the camera moves fast (8 px per frame, above the 6 px fade-out) the memory
// is off, and the masks are exactly those of the frame-to-frame masker.
TEST(FlowMotionMasker, ResidualMemoryIsOffWhileTheCameraMovesFast) {
  FlowMaskOptions frame_to_frame;
  frame_to_frame.residual_memory = 0.0;
  FlowMotionMasker with_memory{FlowMaskOptions()}, without_memory(frame_to_frame);
  const cv::Mat bg = makeTexture(kSize, 33);
  const cv::Mat person = makeTexture(cv::Size(160, 160), 34);
  for (int k = 0; k < 6; ++k) {
    const cv::Rect square(150 + 9 * k, 160, 120, 120);  // 1 px per frame relative to the background
    const cv::Mat frame = squareScene(bg, {8.0 * k, 0}, person, square);
    const FlowMaskResult r = with_memory.compute(frameOf(frame));
    const FlowMaskResult r0 = without_memory.compute(frameOf(frame));
    ASSERT_EQ(r.degraded, r0.degraded) << "frame " << k;
    ASSERT_EQ(r.mask.size(), r0.mask.size());
    EXPECT_EQ(cv::countNonZero(r.mask != r0.mask), 0) << "frame " << k;
  }
}

TEST(FlowMotionMasker, BadInputIsDegradedNotACrash) {
  FlowMotionMasker masker{FlowMaskOptions()};
  const cv::Mat img = makeTexture(kSize, 8);
  masker.compute(frameOf(img));

  const FlowMaskResult empty = masker.compute(RgbdFrame());
  EXPECT_TRUE(empty.degraded);
  EXPECT_NE(empty.message.find("empty colour image"), std::string::npos) << empty.message;

  RgbdFrame mismatched = frameOf(img);
  mismatched.depth_m = cv::Mat::ones(240, 320, CV_32FC1);
  const FlowMaskResult mm = masker.compute(mismatched);
  EXPECT_TRUE(mm.degraded);
  EXPECT_NE(mm.message.find("does not match"), std::string::npos) << mm.message;
  ASSERT_EQ(mm.mask.size(), kSize);
  EXPECT_EQ(cv::countNonZero(mm.mask), 0);

  RgbdFrame wrong_camera = frameOf(img);
  wrong_camera.camera.fx = wrong_camera.camera.fy = 500;
  wrong_camera.camera.width = 320;
  wrong_camera.camera.height = 240;
  EXPECT_TRUE(masker.compute(wrong_camera).degraded);

  const FlowMaskResult wrong_type = masker.compute(frameOf(cv::Mat::zeros(kSize, CV_16UC1)));
  EXPECT_TRUE(wrong_type.degraded);
  EXPECT_NE(wrong_type.message.find("CV_8UC3"), std::string::npos) << wrong_type.message;

  EXPECT_TRUE(masker.compute(frameOf(cv::Mat::zeros(10, 10, CV_8UC3))).degraded);

  // The bad frames did not disturb the history: the same image again is a clean, empty mask.
  const FlowMaskResult same = masker.compute(frameOf(img));
  EXPECT_FALSE(same.degraded) << same.message;
  EXPECT_EQ(cv::countNonZero(same.mask), 0);
}

TEST(FlowMotionMasker, SizeChangeResetsAndRecovers) {
  FlowMotionMasker masker{FlowMaskOptions()};
  masker.compute(frameOf(makeTexture(kSize, 9)));
  const cv::Mat small = makeTexture(cv::Size(320, 240), 10);
  const FlowMaskResult changed = masker.compute(frameOf(small));
  EXPECT_TRUE(changed.degraded);
  EXPECT_NE(changed.message.find("size changed"), std::string::npos) << changed.message;
  ASSERT_EQ(changed.mask.size(), small.size());
  EXPECT_EQ(cv::countNonZero(changed.mask), 0);
  const FlowMaskResult next = masker.compute(frameOf(small));
  EXPECT_FALSE(next.degraded) << next.message;

  masker.reset();
  const FlowMaskResult after_reset = masker.compute(frameOf(small));
  EXPECT_FALSE(after_reset.degraded);
  EXPECT_NE(after_reset.message.find("first frame"), std::string::npos) << after_reset.message;
}

TEST(FlowMotionMasker, GreyInputIsAcceptedAndNotModified) {
  FlowMotionMasker masker{FlowMaskOptions()};
  cv::Mat grey;
  cv::cvtColor(makeTexture(kSize, 11), grey, cv::COLOR_BGR2GRAY);
  const cv::Mat copy = grey.clone();
  masker.compute(frameOf(grey));
  const FlowMaskResult r = masker.compute(frameOf(grey));
  EXPECT_FALSE(r.degraded) << r.message;
  EXPECT_EQ(cv::norm(grey, copy, cv::NORM_INF), 0.0);
}

// The stage times are parts of the whole: flow <= total on every frame, and the first frame (no
// flow yet) spends nothing in the flow while every later one computes one. How long they take is
// measured by bench/mask_synth_bench and bench/mask_vtest_bench, not here.
TEST(FlowMotionMasker, StageTimesArePartsOfTheTotal) {
  FlowMotionMasker masker{FlowMaskOptions()};
  const cv::Mat texture = makeTexture(cv::Size(1000, 800), 12);
  for (int k = 0; k <= 3; ++k) {
    const FlowMaskResult r = masker.compute(frameOf(rotatedView(texture, rotation(0.1 * k, 0.3 * k, 0.1 * k))));
    ASSERT_GE(r.flow_ms, 0.0) << "frame " << k;
    ASSERT_LE(r.flow_ms, r.total_ms) << "frame " << k;
    if (k == 0) {
      EXPECT_TRUE(r.raw_flow_mask.empty());  // nothing to compare with yet
      EXPECT_EQ(r.flow_ms, 0.0);
    } else {
      EXPECT_GT(r.flow_ms, 0.0) << "frame " << k;  // a flow was computed on every later frame
    }
  }
}

// prepareFlow (the flow before the pose is known, MaskStage's live wait) then compute() of the
// same frame gives exactly what compute() alone gives: the same mask, flow and times' parts.
TEST(FlowMotionMasker, FlowPreparedBeforeTheComputeGivesTheSameResult) {
  FlowMotionMasker alone{FlowMaskOptions()};
  FlowMotionMasker prepared{FlowMaskOptions()};
  const cv::Mat bg = makeTexture(kSize, 4);
  const cv::Mat sq = makeTexture(cv::Size(160, 160), 5);
  for (int k = 0; k < 4; ++k) {
    RgbdFrame frame = frameOf(squareScene(bg, cv::Point2d(3.0 * k, 1.0 * k), sq, cv::Rect(200 + 8 * k, 150, 120, 120)));
    frame.stamp_ns = (k + 1) * 33'333'333;
    const auto t0 = std::chrono::steady_clock::now();
    const FlowMaskResult a = alone.compute(frame);
    const auto t1 = std::chrono::steady_clock::now();
    prepared.prepareFlow(frame);
    const FlowMaskResult b = prepared.compute(frame);
    const auto t2 = std::chrono::steady_clock::now();
    // Each part counted once: a total never exceeds the wall time of the calls it covers.
    using Ms = std::chrono::duration<double, std::milli>;
    const double wall_alone_ms = Ms(t1 - t0).count(), wall_prepared_ms = Ms(t2 - t1).count();
    EXPECT_LE(a.total_ms, wall_alone_ms) << "frame " << k;
    EXPECT_LE(b.total_ms, wall_prepared_ms) << "frame " << k;
    ASSERT_EQ(a.degraded, b.degraded) << "frame " << k;
    EXPECT_EQ(a.message, b.message) << "frame " << k;
    ASSERT_EQ(a.mask.size(), b.mask.size()) << "frame " << k;
    EXPECT_EQ(cv::countNonZero(a.mask != b.mask), 0) << "frame " << k;
    ASSERT_EQ(alone.lastFlow().empty(), prepared.lastFlow().empty()) << "frame " << k;
    if (!alone.lastFlow().empty()) {
      EXPECT_EQ(cv::norm(alone.lastFlow(), prepared.lastFlow(), cv::NORM_INF), 0.0) << "frame " << k;
    }
    if (k > 0) {
      EXPECT_GT(cv::countNonZero(b.mask), 0) << "frame " << k;  // the square is found
      EXPECT_GT(b.flow_ms, 0.0) << "frame " << k;
      EXPECT_LE(b.flow_ms, b.total_ms) << "frame " << k;  // the prepared part counts in the total
    }
  }
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mask
}  // namespace dypho
