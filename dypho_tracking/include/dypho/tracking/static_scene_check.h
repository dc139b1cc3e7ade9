#pragma once
/// \file static_scene_check.h
/// Checks a tracked pose against the reference keyframe's static pixels, densely: a coherent
/// group of moving feature matches (people the mask missed) can carry the feature pose, but not
/// the photometric and depth agreement of the whole static background.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/pinhole.h"

namespace dypho {
namespace tracking {

/// Settings of StaticSceneCheck (from TrackingOptions::static_check_*).
struct StaticSceneCheckSettings {
  /// Working resolution: the images are reduced by this factor [-]; the refinement runs at this
  /// and at half of it.
  double scale = 0.5;
  /// Most reference samples per pyramid level [count].
  int max_samples = 3000;
  /// Grey-level gradient a reference sample needs (Sobel / 8, per working pixel) [grey levels].
  double min_gradient = 6.0;
  /// A sample agrees when its brightness-corrected photometric residual is below this
  /// [grey levels] ...
  double photometric_tolerance = 12.0;
  /// ... and the depth measured where it lands is within max(this, 0.015 z^2) of its depth [m].
  double depth_tolerance_m = 0.05;
  /// Gauss-Newton iterations per level of the dense refinement [count].
  int iterations = 12;
};

/// Undistortion maps of one working size, kept while the camera stays the same.
struct UndistortMaps {
  CameraIntrinsics camera;  ///< the camera they were computed for
  cv::Mat map_x, map_y;     ///< cv::initUndistortRectifyMap output (CV_32FC1)
};

/// Share of the reference keyframe's static samples that a pose explains.
struct StaticAgreement {
  int checked = 0;   ///< samples landing in the image on static current pixels with depth [count]
  int agreeing = 0;  ///< of those, photometrically and in depth consistent [count]
  /// agreeing / checked; 0 when nothing was checked.
  double ratio() const { return checked > 0 ? static_cast<double>(agreeing) / checked : 0.0; }
};

/// Dense photometric check of T_current_reference. Usage per frame: setCurrent(), then score()
/// for candidate poses and refine() for the pose that the static background supports best.
/// The reference is replaced with each keyframe (setReference). Images are used without
/// undistortion: fine for the comparison of poses it makes, not for metric accuracy.
class StaticSceneCheck {
 public:
  explicit StaticSceneCheck(const StaticSceneCheckSettings& settings);

  /// Samples the reference keyframe: pixels with a gradient, a valid depth and mask == 0.
  /// `mask` may be empty (all static). Returns false (and keeps no reference) when the frame has
  /// no usable pixels.
  bool setReference(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask);
  /// Prepares the current frame (grey pyramid, gradients, depth, mask at the working sizes).
  void setCurrent(const RgbdFrame& frame, const cv::Mat& mask);
  /// Id of the reference keyframe; -1 when none.
  std::int64_t referenceId() const { return reference_id_; }
  void clear();

  /// Agreement of the reference's static samples with the current frame at T_current_reference.
  StaticAgreement score(const Eigen::Isometry3d& T_current_reference) const;
  /// Robust Gauss-Newton (Huber weights, brightness offset) of the photometric residuals over
  /// the static samples, coarse to fine, from `T_current_reference_init`.
  Eigen::Isometry3d refine(const Eigen::Isometry3d& T_current_reference_init) const;

 private:
  struct Level {
    Pinhole pinhole;
    std::vector<Eigen::Vector3d> p_reference_m;   ///< samples in the reference camera [m]
    std::vector<float> grey_reference;            ///< their grey values
    cv::Mat grey, grad_x, grad_y, depth_m, mask;  ///< current frame at this level (CV_32F / 8U)
  };
  void sampleLevel(const cv::Mat& grey, const cv::Mat& depth_m, const cv::Mat& mask, Level* level) const;
  void refineLevel(const Level& level, Eigen::Isometry3d* T_current_reference) const;

  StaticSceneCheckSettings settings_;
  std::int64_t reference_id_ = -1;
  Level levels_[2];             ///< [0] fine (scale), [1] coarse (scale / 2)
  UndistortMaps undistort_[2];  ///< per level; used when the camera has distortion
};

}  // namespace tracking
}  // namespace dypho
