#pragma once
/// \file yolo_segmenter.h
/// Segment mask of the dynamic classes from a YOLO ONNX model run with OpenCV's dnn module (CPU).
/// Instance-segmentation models give pixel masks from their prototypes; detection-only models
/// give boxes that are cut to their foreground depth cluster (box_depth_segmenter.h).

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "dypho/mask/box_depth_segmenter.h"
#include "dypho/mask/dynamic_mask_options.h"
#include "dypho/mask/yolo_decoder.h"

namespace dypho {
namespace mask {

/// Output of `YoloSegmenter::segment`.
struct SegmentOutput {
  bool ok = false;                        ///< false: no network result (not ready, bad input, forward failed)
  std::string message;                    ///< why not ok
  cv::Mat mask;                           ///< CV_8UC1 image size, 255 = a dynamic-class object (ok only)
  std::vector<YoloDetection> detections;  ///< kept detections (network-input pixels)
  std::vector<cv::Rect> boxes_image;      ///< their boxes in image pixels
  double ms = 0.0;                        ///< wall time: letterbox, forward, decode, masks [ms]
};

/// Loads the model once and segments images. Not thread-safe (one call at a time).
class YoloSegmenter {
 public:
  /// Validates `options` (std::invalid_argument). A missing, unreadable or corrupt model file, or
  /// one whose outputs do not match the layout or input size, does NOT throw: ready() is false
  /// and status() says what is wrong and how to fix it. An empty model_path is "not configured".
  explicit YoloSegmenter(const YoloOptions& options);

  bool ready() const { return ready_; }
  /// "ready: <layout> <input>..." or the reason the network is unavailable.
  const std::string& status() const { return status_; }
  /// The layout in use (valid when ready()).
  const LayoutInfo& layout() const { return layout_; }

  /// Mask of the dynamic classes in `bgr` (CV_8UC3). `depth_m` (CV_32FC1 of the same size, or
  /// empty) is used to cut detector boxes to their foreground; without it boxes are painted whole.
  SegmentOutput segment(const cv::Mat& bgr, const cv::Mat& depth_m);

 private:
  bool forward(const cv::Mat& input_bgr, std::vector<cv::Mat>& outputs, std::string& error);

  YoloOptions options_;
  std::vector<bool> keep_class_;
  BoxDepthSettings box_settings_;
  cv::dnn::Net net_;
  std::vector<std::string> output_names_;
  LayoutInfo layout_;
  bool ready_ = false;
  std::string status_;
  cv::Mat input_;
  cv::Mat blob_;
};

}  // namespace mask
}  // namespace dypho
