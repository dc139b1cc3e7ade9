#pragma once
/// \file mask_cleaner.h
/// Morphological clean-up of a binary dynamic mask: open (remove speckles), drop small connected
/// regions, grow a safety margin. Works at whatever resolution it is given.

#include <opencv2/core.hpp>

namespace dypho {
namespace mask {

/// Settings of `MaskCleaner`, in the pixel units of the mask it is applied to.
struct MaskCleanerSettings {
  int open_radius_px = 1;       ///< radius of the elliptic opening, >= 0 (0 = no opening)
  int min_region_area_px = 25;  ///< 8-connected regions with fewer pixels are removed, >= 0
  int dilate_radius_px = 2;     ///< radius of the elliptic dilation (margin), >= 0 (0 = none)
};

/// Applies open -> small-region removal -> dilation in place. Kernels and label buffers are kept
/// between calls.
class MaskCleaner {
 public:
  explicit MaskCleaner(const MaskCleanerSettings& settings);

  /// `mask`: CV_8UC1, non-zero = dynamic; on return 0/255. Returns the number of regions kept.
  int apply(cv::Mat& mask);

 private:
  MaskCleanerSettings settings_;
  cv::Mat open_kernel_;
  cv::Mat dilate_kernel_;
  cv::Mat labels_;
  cv::Mat stats_;
  cv::Mat centroids_;
};

}  // namespace mask
}  // namespace dypho
