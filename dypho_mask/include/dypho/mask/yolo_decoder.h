#pragma once
/// \file yolo_decoder.h
/// Pure functions that turn the raw output tensors of YOLO ONNX models into detections and pixel
/// masks: letterbox geometry, the supported output layouts, class-wise NMS, prototype masks.
/// No network here (see yolo_segmenter.h), so every layout can be tested on hand-made tensors.
///
/// Supported layouts (B = 1 image, nc classes, nm = 32 mask coefficients, N candidates):
///  - `kYolox`: one output 1 x N x (5 + nc) of RAW head values [x, y, w, h, obj, cls...] on the
///    grids of strides 8, 16, 32 (N = sum (H/s)(W/s)); decode cx = (x + gx) s, w = exp(w) s;
///    score = obj * cls (already sigmoid-ed by the export). YOLOX exports.
///  - `kYolov8`: one output 1 x (4 + nc) x N [cx, cy, w, h, cls...] in input pixels, no
///    objectness. YOLOv8 / YOLO11 detection exports.
///  - `kYolov8Seg`: output0 1 x (4 + nc + nm) x N plus prototypes 1 x nm x mh x mw.
///    YOLOv8-seg / YOLO11-seg exports.
///  - `kYolov5Seg`: output0 1 x N x (5 + nc + nm) [cx, cy, w, h, obj, cls..., coeffs...] plus
///    prototypes 1 x nm x mh x mw. YOLOv5-seg exports.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dypho {
namespace mask {

/// Letterbox: the image is scaled by `scale` (aspect kept) and centred in the network input with
/// padding `pad_x`/`pad_y` [input px] on the left/top (grey 114 around it).
struct Letterbox {
  cv::Size image_size;  ///< original image size [px]
  cv::Size input_size;  ///< network input size [px]
  double scale = 1.0;   ///< input px per image px
  double pad_x = 0.0;   ///< left padding [input px]
  double pad_y = 0.0;   ///< top padding [input px]

  /// Image pixel -> network input pixel.
  cv::Point2d toInput(const cv::Point2d& image_px) const {
    return {image_px.x * scale + pad_x, image_px.y * scale + pad_y};
  }
  /// Network input pixel -> image pixel.
  cv::Point2d toImage(const cv::Point2d& input_px) const {
    return {(input_px.x - pad_x) / scale, (input_px.y - pad_y) / scale};
  }
};

/// Letterbox geometry for an image of `image_size` into `input_size` (both non-empty).
Letterbox makeLetterbox(const cv::Size& image_size, const cv::Size& input_size);

/// Resizes `bgr` (CV_8UC3 of letterbox.image_size) into `input` (CV_8UC3, input_size) with the
/// letterbox, padding 114.
void letterboxImage(const cv::Mat& bgr, const Letterbox& letterbox, cv::Mat& input);

/// Output layouts of YOLO exports (see the file comment).
enum class YoloLayout { kAuto, kYolox, kYolov8, kYolov8Seg, kYolov5Seg };

/// "auto", "yolox", "yolov8", "yolov8_seg", "yolov5_seg" <-> enum. Parsing throws
/// std::invalid_argument listing the valid names.
YoloLayout parseYoloLayout(const std::string& name);
std::string yoloLayoutName(YoloLayout layout);

/// One detection in network-input pixels.
struct YoloDetection {
  cv::Rect2f box_input;       ///< box in network input pixels (x, y = top-left corner)
  int class_id = -1;          ///< COCO class index (0 = person)
  float score = 0.f;          ///< confidence in [0, 1]
  std::vector<float> coeffs;  ///< mask coefficients (seg layouts), empty otherwise
};

/// Decided layout of a set of outputs, with the numbers the decoder needs.
struct LayoutInfo {
  YoloLayout layout = YoloLayout::kAuto;  ///< never kAuto when ok
  int num_classes = 0;
  int num_mask_coeffs = 0;  ///< 0 for detection layouts
  bool ok = false;
  std::string message;  ///< why not ok: the shapes seen and what was expected
};

/// Checks the outputs (as returned by cv::dnn::Net::forward, N-dimensional CV_32F) against
/// `requested` (kAuto: infer from the shapes) for a network input of `input_size`.
/// Auto rules: 2 outputs -> seg (channels-first 1xCxN with C < N: v8-seg, else v5-seg); 1 output
/// 1xNxC with N == number of YOLOX grid cells of input_size -> yolox; 1 output 1xCxN with C < N
/// -> yolov8. Prototypes must be 4-D 1 x nm x mh x mw.
LayoutInfo inspectYoloOutputs(const std::vector<cv::Mat>& outputs, const cv::Size& input_size, YoloLayout requested);

/// Decodes `outputs` with `info` (from inspectYoloOutputs): candidates whose class is in
/// `keep_class` (indexed by class id; empty = all classes) and whose score >= score_threshold,
/// then class-wise NMS with IoU `nms_iou`. Boxes are clipped to the input.
std::vector<YoloDetection> decodeYoloOutputs(const std::vector<cv::Mat>& outputs, const LayoutInfo& info,
                                             const cv::Size& input_size, const std::vector<bool>& keep_class,
                                             float score_threshold, float nms_iou);

/// Instance mask of a seg detection in IMAGE pixels: sigmoid(coeffs . protos) at prototype
/// resolution, upsampled to the network input, cropped to the box, mapped back through the
/// letterbox, > 0.5. `protos` is the 4-D 1 x nm x mh x mw output. ORs 255 into `mask_image`
/// (CV_8UC1, letterbox.image_size).
void paintInstanceMask(const YoloDetection& detection, const cv::Mat& protos, const Letterbox& letterbox,
                       cv::Mat& mask_image);

/// Box of a detection in image pixels (through the letterbox), clipped to the image.
cv::Rect boxInImage(const YoloDetection& detection, const Letterbox& letterbox);

}  // namespace mask
}  // namespace dypho
