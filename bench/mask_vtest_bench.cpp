/// mask_vtest_bench: the motion mask on real people walking (OpenCV's vtest.avi: static camera,
/// 768x576, no depth), scored against YOLOX-nano person boxes as the reference.
///
///   mask_vtest_bench [--video AVI] [--model ONNX] [--frames N] [--threads T] [--background]
///
/// Defaults: --video /usr/share/doc/opencv-doc/examples/data/vtest.avi (Debian package
/// opencv-doc), --model /work/shared/models/yolox_nano.onnx, all frames, 2 OpenCV threads.
/// Motion mask: dypho::mask::DynamicMasker without a network, fed a constant fake depth of 3 m
/// (the video has none), a pinhole camera with f = image width and the identity pose prior
/// T_prev_cur (the camera is static), so the flow path predicts zero ego-motion from depth.
/// The background model is OFF by default: a constant fake depth gives it no evidence (measured
/// with --background: recall 8.1 %, false-dynamic 9.4 %, vs 59.5 % / 1.2 % without).
/// Reference: dypho::mask::YoloSegmenter (layout auto, class person only, score 0.3) on every
/// frame; its boxes_image are the person boxes. Scores (frames 2..N-1, pooled over pixels):
///   recall        = share of person-box pixels covered by the motion mask
///   boxes >= 30 % = share of person boxes whose pixels are at least 30 % covered
///   false-dynamic = share of the pixels outside all person boxes that the mask marks dynamic
/// A person fills only part of its box, so even a perfect person mask has recall below 100 %.
/// Time: DynamicMasker::compute per frame (median, mean) [ms]; the network is not timed in it.

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "dypho/mask/dynamic_masker.h"
#include "dypho/mask/yolo_segmenter.h"
#include "help_flag.h"

using namespace dypho;

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: mask_vtest_bench [--video AVI] [--model ONNX] [--frames N] [--threads T] [--background]\n"
    "The motion mask on OpenCV's vtest.avi (static camera, no depth), scored against YOLOX-nano person\n"
    "boxes. Defaults: --video /usr/share/doc/opencv-doc/examples/data/vtest.avi, --model\n"
    "/work/shared/models/yolox_nano.onnx, all frames, 2 OpenCV threads, background model off.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  std::string video = "/usr/share/doc/opencv-doc/examples/data/vtest.avi";
  std::string model = "/work/shared/models/yolox_nano.onnx";
  int max_frames = -1, threads = 2;
  bool background = false;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << k << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (k == "--video")
      video = value();
    else if (k == "--model")
      model = value();
    else if (k == "--frames")
      max_frames = std::stoi(value());
    else if (k == "--threads")
      threads = std::stoi(value());
    else if (k == "--background")
      background = true;
    else {
      std::cerr << "unknown argument " << k << " (see the file comment)\n";
      return 2;
    }
  }
  cv::setNumThreads(threads);
  cv::VideoCapture capture(video);
  if (!capture.isOpened()) {
    std::cerr << "cannot open " << video << ": install the Debian package opencv-doc "
              << "(scripts/install_deps.sh) or pass --video\n";
    return 1;
  }

  mask::YoloOptions yo;
  yo.model_path = model;
  yo.dynamic_classes = "0";  // person only
  mask::YoloSegmenter detector(yo);
  if (!detector.ready()) {
    std::cerr << "reference detector unavailable: " << detector.status() << "\n";
    return 1;
  }
  mask::DynamicMaskOptions mo;
  mo.background.enabled = background;
  mask::DynamicMasker masker(mo);

  double box_px = 0, box_covered = 0, outside_px = 0, outside_dyn = 0;
  int boxes = 0, boxes_covered = 0, scored = 0;
  std::vector<double> ms;
  cv::Mat bgr;
  mask::MaskPrior prior;
  prior.T_prev_cur = Eigen::Isometry3d::Identity();  // static camera
  for (int i = 0; (max_frames < 0 || i < max_frames) && capture.read(bgr); ++i) {
    RgbdFrame frame;
    frame.stamp_ns = static_cast<Timestamp>(i) * 100'000'000;  // 10 Hz (vtest.avi)
    frame.bgr = bgr;
    frame.depth_m = cv::Mat(bgr.size(), CV_32FC1, cv::Scalar(3.0f));  // fake constant depth
    frame.camera.width = bgr.cols;
    frame.camera.height = bgr.rows;
    frame.camera.fx = frame.camera.fy = bgr.cols;
    frame.camera.cx = bgr.cols / 2.0;
    frame.camera.cy = bgr.rows / 2.0;
    const mask::MaskResult r = masker.compute(frame, prior);
    const mask::SegmentOutput ref = detector.segment(bgr, cv::Mat());
    if (i < 2) continue;  // no flow on the first frame
    if (!ref.ok) {
      std::cerr << "frame " << i << ": detector failed: " << ref.message << "\n";
      return 1;
    }
    ms.push_back(r.total_ms);
    ++scored;
    const cv::Mat dyn = r.mask > 0;
    cv::Mat inside = cv::Mat::zeros(bgr.size(), CV_8UC1);
    const cv::Rect image_rect(0, 0, bgr.cols, bgr.rows);
    for (const cv::Rect& b : ref.boxes_image) {
      const cv::Rect box = b & image_rect;
      if (box.area() <= 0) continue;
      const int covered = cv::countNonZero(dyn(box));
      box_px += box.area();
      box_covered += covered;
      ++boxes;
      if (covered >= 0.3 * box.area()) ++boxes_covered;
      inside(box).setTo(255);
    }
    const cv::Mat outside = inside == 0;
    outside_px += cv::countNonZero(outside);
    outside_dyn += cv::countNonZero(outside & dyn);
  }
  if (scored == 0) {
    std::cerr << "no frames scored (video shorter than 3 frames?)\n";
    return 1;
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  double mean_ms = 0;
  for (double v : ms) mean_ms += v / ms.size();
  std::printf(
      "vtest frames %d  person boxes %d  recall %.1f %% of box px  boxes >= 30 %% covered %.1f %%  "
      "false-dynamic %.2f %% of px outside boxes  mask ms/frame median %.2f mean %.2f  "
      "(background %s, threads %d)\n",
      scored, boxes, 100.0 * box_covered / std::max(1.0, box_px), 100.0 * boxes_covered / std::max(1, boxes),
      100.0 * outside_dyn / std::max(1.0, outside_px), sorted[sorted.size() / 2], mean_ms, background ? "on" : "off",
      threads);
  return 0;
}
