#include "dypho/tracking/feature_preparer.h"

#include <chrono>

#include <opencv2/imgproc.hpp>

namespace dypho {
namespace tracking {

std::string checkTrackingInput(const RgbdFrame& frame, const cv::Mat& mask) {
  const cv::Mat& bgr = frame.bgr;
  if (bgr.empty() || (bgr.type() != CV_8UC3 && bgr.type() != CV_8UC1)) {
    return "colour image is empty or not CV_8UC3 (BGR) / CV_8UC1; convert it before tracking";
  }
  if (bgr.cols < 64 || bgr.rows < 64) return "image smaller than 64x64 px";
  if (frame.depth_m.empty() || frame.depth_m.type() != CV_32FC1) {
    return "depth image is empty or not CV_32FC1 metres (16-bit TUM/OpenNI depth: "
           "convertTo(CV_32F, 1/5000.) or 1/1000.)";
  }
  if (frame.depth_m.size() != bgr.size()) {
    return "depth size differs from the colour size; the depth must be registered to the colour "
           "image";
  }
  if (!frame.camera.valid()) return "camera intrinsics invalid (fx, fy, width, height must be > 0)";
  if (frame.camera.width != bgr.cols || frame.camera.height != bgr.rows) {
    return "camera width/height differ from the image size; scale the intrinsics with the image";
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != bgr.size())) {
    return "mask must be empty or CV_8UC1 with the image size (255 = dynamic)";
  }
  return {};
}

FeaturePreparer::FeaturePreparer(const TrackingOptions& options) : options_(options), extractor_(options) {}

PreparedFeatures FeaturePreparer::prepare(const RgbdFrame& frame, const cv::Mat& mask) {
  const auto t0 = std::chrono::steady_clock::now();
  PreparedFeatures out;
  out.stamp_ns = frame.stamp_ns;
  if (!checkTrackingInput(frame, mask).empty()) return out;
  cv::Mat gray;
  if (frame.bgr.channels() == 3) {
    cv::cvtColor(frame.bgr, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = frame.bgr;
  }
  out.orb = extractor_.extract(gray, mask);
  out.features = makeFrameFeatures(out.orb, frame.depth_m, frame.camera, options_.min_depth_m, options_.max_depth_m);
  out.valid = true;
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace tracking
}  // namespace dypho
