#include "dypho/mask/mask_cleaner.h"

#include <vector>

#include <opencv2/imgproc.hpp>

namespace dypho {
namespace mask {
namespace {

cv::Mat ellipse(int radius) {
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
}

}  // namespace

MaskCleaner::MaskCleaner(const MaskCleanerSettings& settings) : settings_(settings) {
  if (settings_.open_radius_px > 0) open_kernel_ = ellipse(settings_.open_radius_px);
  if (settings_.dilate_radius_px > 0) dilate_kernel_ = ellipse(settings_.dilate_radius_px);
}

int MaskCleaner::apply(cv::Mat& mask) {
  CV_Assert(mask.type() == CV_8UC1);
  if (!open_kernel_.empty()) {
    cv::morphologyEx(mask, mask, cv::MORPH_OPEN, open_kernel_);  // in place (documented by OpenCV)
  }
  const int n = cv::connectedComponentsWithStats(mask, labels_, stats_, centroids_, 8, CV_32S);
  // Label 0 is the background. Keep a label when its area reaches the minimum.
  std::vector<unsigned char> keep(static_cast<std::size_t>(n), 0);
  int kept = 0;
  for (int i = 1; i < n; ++i) {
    if (stats_.at<int>(i, cv::CC_STAT_AREA) >= settings_.min_region_area_px) {
      keep[static_cast<std::size_t>(i)] = 255;
      ++kept;
    }
  }
  if (kept < n - 1) {
    for (int y = 0; y < mask.rows; ++y) {
      const int* l = labels_.ptr<int>(y);
      unsigned char* m = mask.ptr<unsigned char>(y);
      for (int x = 0; x < mask.cols; ++x) m[x] = keep[static_cast<std::size_t>(l[x])];
    }
  } else {
    cv::threshold(mask, mask, 0, 255, cv::THRESH_BINARY);
  }
  if (!dilate_kernel_.empty() && kept > 0) {
    cv::dilate(mask, mask, dilate_kernel_);
  }
  return kept;
}

}  // namespace mask
}  // namespace dypho
