#pragma once
/// \file dense_rgbd_aligner.h
/// Dense RGB-D alignment of a frame to its reference keyframe: photometric and depth residuals
/// over the keyframe's static pixels, coarse to fine, with robust (t-distribution) weights and
/// depth residuals weighted by the sensor's depth noise. It refines the feature pose: the
/// feature estimate enters as a prior with its own information, so the two form one cost.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/pose_covariance.h"
#include "dypho/tracking/pose_optimizer.h"
#include "dypho/tracking/static_scene_check.h"

namespace dypho {
namespace tracking {

/// Settings of DenseRgbdAligner (from TrackingOptions::dense_*).
struct DenseAlignerSettings {
  /// Finest working resolution: the images are reduced by this factor [-]; each further level
  /// halves it.
  double scale = 0.5;
  int levels = 3;                        ///< pyramid levels, coarse to fine [count], >= 1
  int max_photometric_samples = 3000;    ///< photometric samples per level, most [count]
  int max_depth_samples = 1500;          ///< depth samples per level, most [count]
  double min_gradient = 4.0;             ///< grey-level gradient (Sobel / 8) of a photometric sample [grey levels]
  int iterations = 8;                    ///< Gauss-Newton iterations per level, most [count]
  double t_dof = 5.0;                    ///< degrees of freedom of the t-distribution weights (DVO-SLAM: 5) [-]
  double photometric_sigma_floor = 2.0;  ///< smallest photometric noise assumed [grey levels]
  /// Depth noise of a structured-light sensor: sigma(z) = depth_sigma_per_m2 z^2 (Khoshelham and
  /// Elberink 2012 measured 1.4e-3 for the Kinect v1), never below depth_sigma_floor_m [1/m].
  double depth_sigma_per_m2 = 1.425e-3;
  double depth_sigma_floor_m = 0.002;  ///< smallest depth noise assumed [m]
  /// A residual beyond this many sigmas has no weight at all (occlusion, a mover the mask
  /// missed, a specular highlight) [-].
  double max_residual_sigmas = 6.0;
};

/// Depth noise sigma [m] at depth z_m [m] under `settings`.
double depthSigmaM(const DenseAlignerSettings& settings, double z_m);

/// A pose estimate and its information, as a prior for DenseRgbdAligner::align.
struct DensePosePrior {
  Eigen::Isometry3d T_current_reference = Eigen::Isometry3d::Identity();
  PoseInformation information = PoseInformation::Zero();  ///< zero: no prior
};

/// Result of DenseRgbdAligner::align.
struct DenseAlignment {
  bool success = false;  ///< converged on enough samples at the finest level
  Eigen::Isometry3d T_current_reference = Eigen::Isometry3d::Identity();
  int photometric_samples = 0;     ///< photometric residuals used at the finest level [count]
  int depth_samples = 0;           ///< depth residuals used at the finest level [count]
  double photometric_sigma = 0.0;  ///< robust photometric noise at the finest level [grey levels]
  /// Information of the dense residuals alone at the result (no prior).
  PoseInformation information = PoseInformation::Zero();
  std::string message;  ///< why it failed; empty on success
};

/// Dense RGB-D alignment against one reference keyframe. Usage: setReference() per keyframe,
/// setCurrent() per frame, then align() from the feature pose with its prior. Images are
/// undistorted at the working sizes when the camera has distortion.
class DenseRgbdAligner {
 public:
  explicit DenseRgbdAligner(const DenseAlignerSettings& settings);

  /// Samples the reference keyframe: static pixels (mask == 0) with a valid depth away from
  /// depth edges; photometric samples also need a gradient. `mask` may be empty (all static).
  /// Returns false (and keeps no reference) when the frame has too few usable pixels.
  bool setReference(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask);
  /// Prepares the current frame (grey, gradients, depth and its gradients, mask per level).
  void setCurrent(const RgbdFrame& frame, const cv::Mat& mask);
  /// Id of the reference keyframe; -1 when none.
  std::int64_t referenceId() const { return reference_id_; }
  void clear();

  /// Robust Gauss-Newton over the photometric and depth residuals plus `prior`, coarse to fine,
  /// from `T_current_reference_init`.
  DenseAlignment align(const Eigen::Isometry3d& T_current_reference_init, const DensePosePrior& prior) const;

 private:
  struct Level {
    Pinhole pinhole;
    std::vector<Eigen::Vector3d> photometric_p_reference_m;  ///< photometric samples in the reference camera [m]
    std::vector<float> grey_reference;                       ///< their grey values
    std::vector<Eigen::Vector3d> depth_p_reference_m;        ///< depth samples in the reference camera [m]
    cv::Mat grey, grad_x, grad_y;                            ///< current grey and its gradients (CV_32F)
    cv::Mat depth_m, depth_grad_x, depth_grad_y;             ///< current depth and its gradients (CV_32F, NaN: none)
    cv::Mat mask;                                            ///< current mask (CV_8U, 255 = dynamic)
  };
  struct NormalEquations;

  double levelScale(int level) const;
  void sampleReference(const cv::Mat& grey, const cv::Mat& depth_m, const cv::Mat& mask, Level* level) const;
  /// One Gauss-Newton step at `level`; false when too few residuals remain.
  bool step(const Level& level, const DensePosePrior& prior, Eigen::Isometry3d* T_current_reference,
            DenseAlignment* out) const;
  void addPhotometric(const Level& level, const Eigen::Isometry3d& T, NormalEquations* ne, double* sigma) const;
  void addDepth(const Level& level, const Eigen::Isometry3d& T, NormalEquations* ne) const;

  DenseAlignerSettings settings_;
  std::int64_t reference_id_ = -1;
  std::vector<Level> levels_;             ///< [0] finest
  std::vector<UndistortMaps> undistort_;  ///< per level; used when the camera has distortion
};

}  // namespace tracking
}  // namespace dypho
