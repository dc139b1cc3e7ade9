// Decoder tests on hand-made output tensors (every supported layout), letterbox round trips,
// box-to-depth segmentation.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "dypho/mask/box_depth_segmenter.h"
#include "dypho/mask/yolo_decoder.h"

using namespace dypho::mask;

namespace DYPHO_UNITY_ID {

cv::Mat tensor3(int a, int b) {
  const int sizes[3] = {1, a, b};
  return cv::Mat(3, sizes, CV_32F, cv::Scalar(0));
}

float& at3(cv::Mat& m, int i, int j) { return m.ptr<float>(0)[i * m.size[2] + j]; }

TEST(Letterbox, RoundTripAndPadding) {
  const Letterbox lb = makeLetterbox({640, 480}, {416, 416});
  EXPECT_DOUBLE_EQ(lb.scale, 416.0 / 640.0);
  EXPECT_DOUBLE_EQ(lb.pad_x, 0.0);
  EXPECT_DOUBLE_EQ(lb.pad_y, 52.0);  // (416 - 312) / 2
  for (const cv::Point2d p : {cv::Point2d(0, 0), cv::Point2d(639.5, 479.25), cv::Point2d(123.4, 56.7)}) {
    const cv::Point2d q = lb.toImage(lb.toInput(p));
    EXPECT_NEAR(q.x, p.x, 1e-9);  // pure affine map: exact up to rounding
    EXPECT_NEAR(q.y, p.y, 1e-9);
  }
  cv::Mat img(480, 640, CV_8UC3, cv::Scalar(10, 20, 30)), in;
  letterboxImage(img, lb, in);
  ASSERT_EQ(in.size(), cv::Size(416, 416));
  EXPECT_EQ(in.at<cv::Vec3b>(10, 200), cv::Vec3b(114, 114, 114));   // top padding
  EXPECT_EQ(in.at<cv::Vec3b>(208, 200), cv::Vec3b(10, 20, 30));     // image
  EXPECT_EQ(in.at<cv::Vec3b>(410, 200), cv::Vec3b(114, 114, 114));  // bottom padding
  // Portrait image: padding left/right.
  const Letterbox lp = makeLetterbox({300, 600}, {640, 640});
  EXPECT_DOUBLE_EQ(lp.pad_y, 0.0);
  EXPECT_DOUBLE_EQ(lp.pad_x, 160.0);
}

TEST(YoloDecoder, YoloxRawGridDecode) {
  const cv::Size in(64, 64);  // grids 8x8 + 4x4 + 2x2 = 84 cells
  cv::Mat out = tensor3(84, 5 + 3);
  // Stride-16 cell (gx=2, gy=1) is row 64 + 1*4 + 2 = 70: centre (2.5+2)*16 = 72? use x=0.5,y=0.5.
  const int row = 64 + 1 * 4 + 2;
  at3(out, row, 0) = 0.5f;
  at3(out, row, 1) = 0.25f;
  at3(out, row, 2) = std::log(1.5f);  // w = 1.5 * 16 = 24
  at3(out, row, 3) = std::log(2.0f);  // h = 32
  at3(out, row, 4) = 0.9f;            // objectness
  at3(out, row, 5 + 0) = 0.8f;        // person
  const LayoutInfo info = inspectYoloOutputs({out}, in, YoloLayout::kAuto);
  ASSERT_TRUE(info.ok) << info.message;
  EXPECT_EQ(info.layout, YoloLayout::kYolox);
  EXPECT_EQ(info.num_classes, 3);
  const auto dets = decodeYoloOutputs({out}, info, in, {}, 0.3f, 0.45f);
  ASSERT_EQ(dets.size(), 1u);
  EXPECT_EQ(dets[0].class_id, 0);
  EXPECT_NEAR(dets[0].score, 0.72f, 1e-6);
  // cx = (0.5 + 2) * 16 = 40, cy = (0.25 + 1) * 16 = 20 -> box x 28..52, y 4..36.
  EXPECT_NEAR(dets[0].box_input.x, 28.f, 1e-4);
  EXPECT_NEAR(dets[0].box_input.y, 4.f, 1e-4);
  EXPECT_NEAR(dets[0].box_input.width, 24.f, 1e-4);
  EXPECT_NEAR(dets[0].box_input.height, 32.f, 1e-4);
  // Class filter drops it when person is not dynamic.
  EXPECT_TRUE(decodeYoloOutputs({out}, info, in, {false, true, true}, 0.3f, 0.45f).empty());
}

TEST(YoloDecoder, Yolov8DetectionChannelsFirstWithNms) {
  const cv::Size in(64, 64);
  cv::Mat out = tensor3(4 + 2, 100);
  auto put = [&](int i, float cx, float cy, float w, float h, int c, float s) {
    at3(out, 0, i) = cx;
    at3(out, 1, i) = cy;
    at3(out, 2, i) = w;
    at3(out, 3, i) = h;
    at3(out, 4 + c, i) = s;
  };
  put(3, 20, 20, 10, 10, 1, 0.9f);
  put(4, 21, 20, 10, 10, 1, 0.7f);  // overlaps 3 (IoU 0.82): suppressed
  put(5, 21, 20, 10, 10, 0, 0.6f);  // same box, other class: kept (class-wise NMS)
  const LayoutInfo info = inspectYoloOutputs({out}, in, YoloLayout::kAuto);
  ASSERT_TRUE(info.ok) << info.message;
  EXPECT_EQ(info.layout, YoloLayout::kYolov8);
  const auto dets = decodeYoloOutputs({out}, info, in, {}, 0.3f, 0.45f);
  ASSERT_EQ(dets.size(), 2u);
  EXPECT_EQ(dets[0].class_id, 1);
  EXPECT_NEAR(dets[0].box_input.x, 15.f, 1e-4);
  EXPECT_EQ(dets[1].class_id, 0);
}

TEST(YoloDecoder, SegLayoutsGiveTheSameInstanceMask) {
  const cv::Size in(64, 64);
  const int nc = 2, nm = 4, n = 50;
  const int psz[4] = {1, nm, 16, 16};
  cv::Mat protos(4, psz, CV_32F, cv::Scalar(0));
  // Prototype 1: +5 on proto rows/cols [4, 12) (input [16, 48)), -5 elsewhere.
  float* p1 = protos.ptr<float>(0) + 1 * 256;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) p1[y * 16 + x] = (x >= 4 && x < 12 && y >= 4 && y < 12) ? 5.f : -5.f;
  cv::Mat v8 = tensor3(4 + nc + nm, n);
  at3(v8, 0, 7) = 32;
  at3(v8, 1, 7) = 32;
  at3(v8, 2, 7) = 60;
  at3(v8, 3, 7) = 60;
  at3(v8, 4 + 0, 7) = 0.9f;
  at3(v8, 4 + nc + 1, 7) = 1.f;
  cv::Mat v5 = tensor3(n, 5 + nc + nm);
  at3(v5, 7, 0) = 32;
  at3(v5, 7, 1) = 32;
  at3(v5, 7, 2) = 60;
  at3(v5, 7, 3) = 60;
  at3(v5, 7, 4) = 1.f;
  at3(v5, 7, 5 + 0) = 0.9f;
  at3(v5, 7, 5 + nc + 1) = 1.f;
  const Letterbox lb = makeLetterbox({128, 64}, in);  // image 2:1 -> scale 0.5, pad_y 16
  for (auto [outs, expected] : {std::make_pair(std::vector<cv::Mat>{v8, protos}, YoloLayout::kYolov8Seg),
                                std::make_pair(std::vector<cv::Mat>{v5, protos}, YoloLayout::kYolov5Seg)}) {
    const LayoutInfo info = inspectYoloOutputs(outs, in, YoloLayout::kAuto);
    ASSERT_TRUE(info.ok) << info.message;
    EXPECT_EQ(info.layout, expected);
    EXPECT_EQ(info.num_classes, nc);
    EXPECT_EQ(info.num_mask_coeffs, nm);
    const auto dets = decodeYoloOutputs(outs, info, in, {}, 0.3f, 0.45f);
    ASSERT_EQ(dets.size(), 1u);
    cv::Mat m = cv::Mat::zeros(64, 128, CV_8UC1);
    paintInstanceMask(dets[0], outs[1], lb, m);
    // Input square [16, 48)^2 -> image x [32, 96), y [0, 64): 64 x 64 pixels; bilinear
    // upsampling of the +-5 step puts the 0 crossing at the boundary (+-1 px tolerance).
    const int area = cv::countNonZero(m);
    EXPECT_NEAR(area, 64 * 64, 2 * 64 + 2 * 64 + 4);
    EXPECT_EQ(m.at<uchar>(32, 64), 255);
    EXPECT_EQ(m.at<uchar>(32, 10), 0);
  }
}

TEST(YoloDecoder, WrongLayoutsAreReported) {
  const cv::Size in(64, 64);
  const int sz4[4] = {1, 3, 4, 5};
  const LayoutInfo a = inspectYoloOutputs({cv::Mat(4, sz4, CV_32F, cv::Scalar(0))}, in, YoloLayout::kAuto);
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.message.find("1x3x4x5"), std::string::npos) << a.message;
  const LayoutInfo b = inspectYoloOutputs({tensor3(90, 85)}, in, YoloLayout::kAuto);  // 90 != 84 cells, 90 > 85
  EXPECT_FALSE(b.ok);
  const LayoutInfo c = inspectYoloOutputs({tensor3(84, 85)}, in, YoloLayout::kYolov8Seg);  // needs 2 outputs
  EXPECT_FALSE(c.ok);
  EXPECT_THROW(parseYoloLayout("yolov9"), std::invalid_argument);
}

TEST(BoxDepthSegmenter, BoxKeepsTheForegroundNotTheWall) {
  cv::Mat depth(100, 100, CV_32FC1, cv::Scalar(4.0f));  // wall at 4 m
  depth(cv::Rect(40, 20, 20, 70)).setTo(2.0f);          // person at 2 m
  depth(cv::Rect(45, 30, 3, 3)).setTo(0.f);             // hole inside the person
  cv::Mat m = cv::Mat::zeros(100, 100, CV_8UC1);
  EXPECT_TRUE(paintBoxForeground(depth, cv::Rect(30, 10, 40, 85), BoxDepthSettings(), m));
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(40, 20, 20, 70))), 20 * 70);  // person incl. the hole
  EXPECT_EQ(cv::countNonZero(m), 20 * 70);                            // nothing of the wall
  cv::Mat m2 = cv::Mat::zeros(100, 100, CV_8UC1);
  EXPECT_FALSE(paintBoxForeground(cv::Mat(), cv::Rect(30, 10, 40, 85), BoxDepthSettings(), m2));
  EXPECT_EQ(cv::countNonZero(m2), 40 * 85);  // depth-free mode: whole box
  cv::Mat zero = cv::Mat::zeros(100, 100, CV_32FC1), m3 = cv::Mat::zeros(100, 100, CV_8UC1);
  EXPECT_FALSE(paintBoxForeground(zero, cv::Rect(30, 10, 40, 85), BoxDepthSettings(), m3));
  EXPECT_EQ(cv::countNonZero(m3), 40 * 85);  // depth all zero: whole box (documented)
}

TEST(BoxDepthSegmenter, RegionHaloOnTheWallIsCut) {
  cv::Mat depth(100, 100, CV_32FC1, cv::Scalar(4.0f));
  depth(cv::Rect(40, 20, 20, 70)).setTo(2.0f);
  cv::Mat m = cv::Mat::zeros(100, 100, CV_8UC1);
  m(cv::Rect(35, 15, 30, 80)).setTo(255);  // person + 5 px halo
  cutRegionsToDepthForeground(depth, BoxDepthSettings(), m);
  EXPECT_EQ(cv::countNonZero(m), 20 * 70);
}

// A crowd: one flow region spans a person at 1.5 m and another, partly behind, at 3 m, with a
// 5 px halo on the wall (5 m). The nearest-layer cut keeps only the first person; the layered cut
// keeps both and still nothing of the wall: neither its 5 px halo band (no wider than the halo)
// nor a 25 px wide strip of it (wide, but the region's own far depth, not in front of it).
TEST(BoxDepthSegmenter, CrowdRegionKeepsPeopleBehindPeopleNotTheWall) {
  cv::Mat depth(120, 160, CV_32FC1, cv::Scalar(5.0f));
  const cv::Rect near_person(20, 20, 30, 80), far_person(60, 20, 30, 80);
  depth(near_person).setTo(1.5f);
  depth(far_person).setTo(3.0f);
  cv::Mat region = cv::Mat::zeros(depth.size(), CV_8UC1);
  region(cv::Rect(15, 15, 100, 90)).setTo(255);  // both people + halo + 25 px of wall on the right
  const int halo_px = 5;

  cv::Mat nearest = region.clone();
  cutRegionsToDepthLayers(depth, BoxDepthSettings(), halo_px, 1, nearest);
  EXPECT_EQ(cv::countNonZero(nearest), near_person.area());
  EXPECT_EQ(cv::countNonZero(nearest(near_person)), near_person.area());

  cv::Mat layered = region.clone();
  cutRegionsToDepthLayers(depth, BoxDepthSettings(), halo_px, 3, layered);
  EXPECT_EQ(cv::countNonZero(layered(near_person)), near_person.area());
  EXPECT_EQ(cv::countNonZero(layered(far_person)), far_person.area());
  EXPECT_EQ(cv::countNonZero(layered), near_person.area() + far_person.area());  // no wall

  // One person and the halo only: the same result as the nearest-layer cut.
  cv::Mat single_depth(100, 100, CV_32FC1, cv::Scalar(4.0f));
  single_depth(cv::Rect(40, 20, 20, 70)).setTo(2.0f);
  cv::Mat single = cv::Mat::zeros(100, 100, CV_8UC1);
  single(cv::Rect(35, 15, 30, 80)).setTo(255);
  cutRegionsToDepthLayers(single_depth, BoxDepthSettings(), halo_px, 3, single);
  EXPECT_EQ(cv::countNonZero(single), 20 * 70);
}

// The depth growth fills an object whose outline the flow found, but not a surface that reaches
// far beyond the region: a flow region on a desk seen before the background has a value grew
// over the whole desk. No background value anywhere here (the first frames).
TEST(BoxDepthSegmenter, GrowthFillsAPersonButNotADesk) {
  const cv::Mat no_background = cv::Mat::zeros(100, 160, CV_32FC1);
  DepthGrowSettings settings;
  settings.max_growth_ratio = 8.0;

  // A desk: one slanted surface over the whole view (1.0-1.2 m), a 15 x 15 px flow region on it.
  cv::Mat desk(100, 160, CV_32FC1);
  for (int y = 0; y < desk.rows; ++y) desk.row(y).setTo(1.0f + 0.002f * static_cast<float>(y));
  const cv::Rect seed(70, 40, 15, 15);
  cv::Mat on_desk = cv::Mat::zeros(desk.size(), CV_8UC1);
  on_desk(seed).setTo(255);
  cv::Mat unlimited = on_desk.clone();
  growRegionsInDepth(desk, no_background, DepthGrowSettings(), unlimited);
  EXPECT_EQ(cv::countNonZero(unlimited), desk.rows * desk.cols);  // without a limit: the whole desk
  growRegionsInDepth(desk, no_background, settings, on_desk);
  EXPECT_EQ(cv::countNonZero(on_desk), seed.area());  // with it: the region as found
  EXPECT_EQ(cv::countNonZero(on_desk(seed)), seed.area());

  // A person at 2 m before a wall at 4 m, the flow on the left half of the body: filled whole.
  cv::Mat room(100, 160, CV_32FC1, cv::Scalar(4.0f));
  const cv::Rect person(40, 20, 20, 70);
  room(person).setTo(2.0f);
  cv::Mat outline = cv::Mat::zeros(room.size(), CV_8UC1);
  outline(cv::Rect(40, 20, 10, 70)).setTo(255);
  growRegionsInDepth(room, no_background, settings, outline);
  EXPECT_EQ(cv::countNonZero(outline(person)), person.area());
  EXPECT_EQ(cv::countNonZero(outline), person.area());
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
