#include "dypho/mask/yolo_segmenter.h"

#include <algorithm>
#include <chrono>
#include <fstream>

namespace dypho {
namespace mask {

YoloSegmenter::YoloSegmenter(const YoloOptions& options) : options_((options.validate(), options)) {
  for (int id : options_.dynamicClassIds()) {
    if (id >= static_cast<int>(keep_class_.size())) keep_class_.resize(id + 1, false);
    keep_class_[id] = true;
  }
  box_settings_.depth_range_m = options_.box_depth_range_m;
  if (options_.model_path.empty()) {
    status_ = "no YOLO model configured (yolo_model_path empty): segment mask off, flow and background only";
    return;
  }
  if (!std::ifstream(options_.model_path).good()) {
    status_ =
        "YOLO model '" + options_.model_path + "' not found or unreadable: segment mask off (fix yolo_model_path)";
    return;
  }
  try {
    net_ = cv::dnn::readNetFromONNX(options_.model_path);
  } catch (const cv::Exception& e) {
    status_ = "YOLO model '" + options_.model_path +
              "' could not be loaded as ONNX (corrupt or unsupported: " + e.what() + "): segment mask off";
    return;
  }
  if (net_.empty()) {
    status_ = "YOLO model '" + options_.model_path + "' loaded as an empty network: segment mask off";
    return;
  }
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  output_names_ = net_.getUnconnectedOutLayersNames();
  // One forward pass on a grey image checks the input size and the output layout now, not on the
  // first real frame.
  const cv::Size in(options_.input_size_px, options_.input_size_px);
  std::vector<cv::Mat> outputs;
  std::string error;
  if (!forward(cv::Mat(in, CV_8UC3, cv::Scalar(114, 114, 114)), outputs, error)) {
    status_ = "YOLO model '" + options_.model_path + "' failed on a " + std::to_string(in.width) + "x" +
              std::to_string(in.height) + " input (" + error +
              "); set yolo_input_size_px to the size the model was exported at: segment mask off";
    return;
  }
  layout_ = inspectYoloOutputs(outputs, in, parseYoloLayout(options_.layout));
  if (!layout_.ok) {
    status_ = "YOLO model '" + options_.model_path + "': " + layout_.message + ": segment mask off";
    return;
  }
  ready_ = true;
  status_ = "YOLO model '" + options_.model_path + "' ready: layout " + yoloLayoutName(layout_.layout) + ", " +
            std::to_string(layout_.num_classes) + " classes, input " + std::to_string(in.width) + "x" +
            std::to_string(in.height);
}

bool YoloSegmenter::forward(const cv::Mat& input_bgr, std::vector<cv::Mat>& outputs, std::string& error) {
  // YOLOX exports take BGR 0..255; Ultralytics exports (v5/v8/v11) RGB 0..1.
  const bool ultralytics = layout_.ok && layout_.layout != YoloLayout::kYolox;
  cv::dnn::blobFromImage(input_bgr, blob_, ultralytics ? 1.0 / 255.0 : 1.0, cv::Size(), cv::Scalar(),
                         /*swapRB=*/ultralytics, /*crop=*/false, CV_32F);
  try {
    net_.setInput(blob_);
    net_.forward(outputs, output_names_);
  } catch (const cv::Exception& e) {
    error = e.what();
    return false;
  }
  // Detections first, prototypes (4-D) second, whatever the export's output order.
  std::stable_sort(outputs.begin(), outputs.end(), [](const cv::Mat& a, const cv::Mat& b) { return a.dims < b.dims; });
  return true;
}

SegmentOutput YoloSegmenter::segment(const cv::Mat& bgr, const cv::Mat& depth_m) {
  const auto t0 = std::chrono::steady_clock::now();
  SegmentOutput out;
  if (!ready_) {
    out.message = status_;
    return out;
  }
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    out.message = "segment mask needs a CV_8UC3 colour image";
    return out;
  }
  const cv::Size in(options_.input_size_px, options_.input_size_px);
  const Letterbox lb = makeLetterbox(bgr.size(), in);
  letterboxImage(bgr, lb, input_);
  std::vector<cv::Mat> outputs;
  std::string error;
  if (!forward(input_, outputs, error)) {
    out.message = "YOLO forward failed: " + error;
    return out;
  }
  const LayoutInfo info = inspectYoloOutputs(outputs, in, layout_.layout);
  if (!info.ok) {
    out.message = info.message;
    return out;
  }
  out.detections = decodeYoloOutputs(outputs, info, in, keep_class_, static_cast<float>(options_.score_threshold),
                                     static_cast<float>(options_.nms_iou));
  out.mask = cv::Mat::zeros(bgr.size(), CV_8UC1);
  const cv::Mat depth = depth_m.size() == bgr.size() && depth_m.type() == CV_32FC1 ? depth_m : cv::Mat();
  for (const YoloDetection& d : out.detections) {
    out.boxes_image.push_back(boxInImage(d, lb));
    if (info.num_mask_coeffs > 0) {
      paintInstanceMask(d, outputs[1], lb, out.mask);
    } else {
      paintBoxForeground(depth, out.boxes_image.back(), box_settings_, out.mask);
    }
  }
  out.ok = true;
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace mask
}  // namespace dypho
