#pragma once
/// \file flow_motion_masker.h
/// Dynamic-object mask from dense optical flow with the camera-induced motion removed.
///
/// The paper (Sec. "Dynamic Process", motion mask) thresholds the raw flow magnitude
/// ||(u, v)||^2 > T. As soon as the camera moves, every pixel has a large flow and that rule masks
/// the whole image. The masker removes the camera's own motion first and thresholds only the
/// residual flow: the motion is fitted robustly to the flow field (RANSAC on a grid of flow
/// samples), from depth and the tracked pose where they exist (ego_motion.h), else as a
/// homography, exact for a rotating camera and close for small translations or distant scenes.
/// With depth and a stale prediction (`compute`'s PoseFitUse::kEgoMotion), the relative pose itself
/// is first fitted to the flow (fit_rigid_motion), so that the prediction's translation error does
/// not stay in the residual; with a fresh one (PoseFitUse::kReport) the fit is only reported, for
/// the background model's warp (BackgroundOptions::warp_with_flow_fit).
/// The YOLO segment mask and the background model B_i are fused with this mask by DynamicMasker.
///
/// Pipeline per frame: grey -> resize by flow_scale -> DIS flow current->previous (so the mask
/// lies on the objects' current positions) -> correspondences in full-resolution pixels
/// (undistorted when the camera has distortion) -> RANSAC homography on a grid of textured samples
/// -> residual magnitude > residual_threshold_px on textured pixels -> open, drop small regions,
/// dilate (at flow resolution) -> upsample to the input size -> reject when above
/// max_masked_fraction. Known limits: textureless moving surfaces are only masked through their
/// textured border plus the margin; when moving objects cover most of the textured view the fit
/// is tried again without the previous frame's dynamic pixels, and when it still fails the result
/// is degraded and carries the previous mask along the flow.

#include <memory>
#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mask/flow_mask_options.h"
#include "dypho/mask/global_motion.h"
#include "dypho/mask/mask_cleaner.h"

namespace cv {
class DISOpticalFlow;
}

namespace dypho {
namespace mask {

/// What `FlowMotionMasker::compute` fits the given relative pose to the flow for.
enum class PoseFitUse {
  kNone,       ///< no fit: the ego-motion uses the given pose
  kReport,     ///< fitted and reported (FlowMaskResult::T_prev_cur_fitted); the ego-motion uses the given pose
  kEgoMotion,  ///< fitted, reported and used for the ego-motion
};

/// Output of `FlowMotionMasker::compute`.
struct FlowMaskResult {
  /// Final mask, CV_8UC1, input size, 255 = dynamic, 0 = static. When degraded: the previous
  /// frame's mask carried along the flow (see compute()), all static when there is none.
  cv::Mat mask;
  /// Thresholded residual before opening, region filtering and margin, CV_8UC1, input size,
  /// 255 = residual above threshold (empty when no flow was computed).
  cv::Mat raw_flow_mask;
  /// Fraction of `mask` pixels that are dynamic, in [0, 1].
  double masked_fraction = 0.0;
  /// True when the mask could not be trusted: bad input, size change, failed global-motion fit or
  /// too much of the image masked. `mask` is then all static (bad input, size change) or the
  /// carried previous mask, and `message` says why.
  bool degraded = false;
  /// Human-readable note: why degraded, or "first frame" (empty otherwise).
  std::string message;
  /// Global motion mapping a current pixel to its previous position, in full-resolution pixels
  /// (undistorted pixels of the same K when the frame's camera has distortion).
  cv::Matx33d H_prev_cur = cv::Matx33d::eye();
  /// Fraction of flow samples that follow the global motion, in [0, 1].
  double inlier_ratio = 0.0;
  /// True when the camera motion was removed with depth + the given relative pose (rigid flow,
  /// refined by a homography for rotation errors of the prediction); false when the global
  /// homography alone was used (no pose, no depth, no valid camera, or the pose did not fit).
  bool ego_motion_from_pose = false;
  /// The relative pose (current camera in the previous one) behind the rigid prediction when
  /// ego_motion_from_pose: fitted to the flow (FlowMaskOptions::fit_rigid_motion) or as given.
  std::optional<Eigen::Isometry3d> T_prev_cur;
  /// The relative pose fitted to the flow and the depth from the given one, when compute() was
  /// asked to fit (PoseFitUse other than kNone) and had depth, a valid camera and a pose; the
  /// given pose itself when the fit did not explain clearly more of the flow.
  std::optional<Eigen::Isometry3d> T_prev_cur_fitted;
  /// True when the global motion was found only without the previous frame's dynamic pixels
  /// (the plain fit had too few inliers; see compute()).
  bool fit_excluded_previous_mask = false;
  /// True when the global motion was not found and no previous mask could be carried: nothing
  /// says which pixels move (the mask is all static for want of evidence, not because of it).
  bool motion_unknown = false;
  /// How still the camera is, in [0, 1]: 1 while the median flow of the textured pixels (the
  /// camera's own image motion while people cover less than half of the view) is below 2 px per
  /// frame, 0 from 6 px on, linear between (full-res). The ego-motion model's errors grow with
  /// the camera's motion; evidence that adds up over frames (residual memory) or widens a region
  /// (depth layers) is used only in proportion. 0 when there was no flow.
  double still_camera_weight = 0.0;
  /// Median flow length of the textured pixels [full-res px] behind still_camera_weight (0 when
  /// there was no flow).
  double median_flow_px = 0.0;
  /// Median flow length of the textured pixels the ego-motion explains (residual under
  /// residual_threshold_px) [full-res px]: the image motion of the static scene, which people
  /// filling the view do not change. 0 when there are none or no fit.
  double static_median_flow_px = 0.0;
  /// Share of the textured pixels whose flow is under 0.5 px per frame (full-res), in [0, 1]: the
  /// part of the view that does not move at all (0 when there was no flow).
  double quiet_flow_share = 0.0;
  double flow_ms = 0.0;   ///< wall time of the optical flow [ms]
  double total_ms = 0.0;  ///< wall time of the whole `compute` call [ms]
};

/// Computes the motion mask of each frame against the previous one. Not thread-safe; one instance
/// per image stream. The first frame (and the first after `reset()` or after a size change) has no
/// predecessor and gives an all-static mask.
class FlowMotionMasker {
 public:
  /// Validates `options` (std::invalid_argument on a bad value).
  explicit FlowMotionMasker(const FlowMaskOptions& options);
  ~FlowMotionMasker();
  FlowMotionMasker(const FlowMotionMasker&) = delete;
  FlowMotionMasker& operator=(const FlowMotionMasker&) = delete;

  /// Mask of `frame.bgr` (CV_8UC3 BGR, or CV_8UC1 grey). `frame.depth_m` is not used but, when
  /// given, must match the colour size, as must `frame.camera` when it is valid. When the camera
  /// is valid and distorted, the global motion is fitted in undistorted pixel coordinates (where a
  /// camera rotation is exactly a homography); otherwise in raw pixel coordinates. Bad input gives
  /// a degraded all-static result (input size when known) and leaves the history untouched.
  ///
  /// `T_prev_cur` (optional): predicted pose of the current camera in the previous camera frame.
  /// With it, a valid camera and a depth image, the camera's own motion is predicted per pixel
  /// from depth (rigid flow, see ego_motion.h); a homography fitted between predicted and
  /// measured positions absorbs rotation errors of the prediction, and the residual is
  /// thresholded. Pixels without depth carry no evidence in that mode. When the prediction does
  /// not fit the measured flow (fewer than min_inlier_ratio agree), or without a pose, the global
  /// homography of the plain flow is removed instead (the fallback).
  ///
  /// `previous_dynamic` (optional, CV_8UC1 of the input size, non-zero = dynamic): the final mask
  /// of the previous frame. It is carried into the current frame along the flow. When fewer than
  /// min_inlier_ratio of the samples follow one motion, or when the fit explains the carried
  /// pixels clearly better than the rest (it locked onto a group of people), the fit is tried
  /// again without the carried pixels (in a crowd most flow samples lie on people, and the static
  /// remainder alone defines the camera's motion; the inlier ratio then counts the remainder).
  /// When the fit fails all the same, the result is degraded but its mask is the carried previous
  /// mask (shrunk by the margin, which the caller grows again) instead of an empty one: an empty
  /// mask would hand every person to the tracker.
  ///
  /// `fit`: whether the relative pose `T_prev_cur` (when given) is fitted to the flow and the
  /// depth, and what for (PoseFitUse; DynamicMasker decides from FlowMaskOptions::fit_rigid_motion
  /// and BackgroundOptions::warp_with_flow_fit).
  FlowMaskResult compute(const RgbdFrame& frame, const std::optional<Eigen::Isometry3d>& T_prev_cur = std::nullopt,
                         const cv::Mat& previous_dynamic = cv::Mat(), PoseFitUse fit = PoseFitUse::kNone);

  /// The part of compute() that needs no pose: the input check, the grey image and the dense
  /// flow (most of its time). A compute() of the same frame (stamp) that follows starts after it
  /// with the same result, so that a caller can wait for the pose meanwhile (MaskStage).
  void prepareFlow(const RgbdFrame& frame);

  /// Backward flow of the last compute() (current -> previous image) at flow resolution
  /// [flow px], CV_32FC2; empty when the last call computed none (first frame, bad input).
  const cv::Mat& lastFlow() const { return last_flow_valid_ ? flow_ : empty_; }
  /// The previous frame's mask carried along the flow into the last computed frame (CV_8UC1,
  /// 255 = dynamic, flow resolution); empty when there was none.
  const cv::Mat& carriedPrevious() const { return carried_; }

  /// Forgets the previous image; the next frame is treated as a first frame.
  void reset();

  /// Switches the residual memory (FlowMaskOptions::residual_memory) on or off from the next
  /// compute() on; off forgets it. On by default. The DynamicMasker switches it off while a
  /// segmentation network is running: the network finds slow people whatever their speed.
  void setResidualMemoryEnabled(bool enabled);

  /// Catch-up mode (MaskPrior::catching_up) from the next compute() on: the flow runs without its
  /// variational refinement (FlowMaskOptions::dis_refinement_iterations) and with fewer patches
  /// (FlowMaskOptions::dis_catch_up_patch_stride, dis_catch_up_iterations), until switched off.
  void setCatchingUp(bool catching_up) { catching_up_ = catching_up; }

  /// The options in use.
  const FlowMaskOptions& options() const { return options_; }

 private:
  bool checkInput(const RgbdFrame& frame, FlowMaskResult& result) const;
  /// cur_small_ = grey of `bgr` reduced by flow_scale; returns its size (flow resolution).
  cv::Size reduceGrey(const cv::Mat& bgr);
  /// True when the previous image is of `input_size`; else starts the history with cur_small_
  /// (first frame or size change, said in `result`) and returns false.
  bool continueHistory(const cv::Size& input_size, FlowMaskResult& result);
  /// flow_ = backward DIS flow cur_small_ -> prev_small_ [flow px]; texture of cur_small_, which
  /// then becomes prev_small_. Sets result.flow_ms.
  void computeFlow(FlowMaskResult& result);
  /// prev_px_ = full-resolution (undistorted) previous position of each grid_px_ along flow_
  /// (flow_target_: the same in flow px).
  void computeCorrespondences(const cv::Size& input_size, const cv::Size& small_size, const CameraIntrinsics& camera);
  /// The camera's own motion: the fit (pose + depth, else homography; retried without the carried
  /// pixels) and its residual_. False (result degraded, carried mask) when no fit was found.
  bool fitEgoMotion(const RgbdFrame& frame, const cv::Size& small_size,
                    const std::optional<Eigen::Isometry3d>& T_prev_cur, PoseFitUse fit, FlowMaskResult& result);
  /// predicted_px_ = rigid prediction of the previous positions from depth_small_ (fitEgoMotion
  /// reduces the depth once per frame) and `T_prev_cur`;
  /// usable_ = textured cells that have one.
  void predictFromPose(const RgbdFrame& frame, const Eigen::Isometry3d& T_prev_cur);
  /// The relative pose fitted to the flow and depth from `T_prev_cur`; `T_prev_cur` unless the
  /// fit explains clearly more cells.
  Eigen::Isometry3d fitRigid(const RgbdFrame& frame, const cv::Size& small_size, const Eigen::Isometry3d& T_prev_cur);
  /// One global-motion fit, from the pose prediction first when `with_pose`, then from the grid;
  /// without the carried pixels when `exclude_previous`. `from_pose`: which one was fitted last.
  GlobalMotionFit fitOnce(bool with_pose, bool exclude_previous, bool& from_pose);
  /// The fit again without the carried pixels (see the .cpp); `fit`, `from_pose`, residual_ and
  /// result.fit_excluded_previous_mask are replaced when it is taken.
  void refitWithoutCarried(bool with_pose, GlobalMotionFit& fit, bool& from_pose, FlowMaskResult& result);
  /// residual_ (and residual_vec_) of `fit` [full-res px], aperture-weighted when configured.
  void computeResidual(const GlobalMotionFit& fit, bool from_pose);
  /// Sets the flow statistics and result.still_camera_weight.
  void weighStillCamera(FlowMaskResult& result) const;
  /// small_mask_ = textured residual_ above residual_threshold_px (flow resolution);
  /// result.raw_flow_mask = it at input size.
  void thresholdResidual(const cv::Size& input_size, FlowMaskResult& result);
  void finishMask(const cv::Size& input_size, FlowMaskResult& result);
  /// carried_ = `previous_dynamic` moved along the flow into the current frame (flow resolution);
  /// empty when `previous_dynamic` is empty or of another size.
  void carryPrevious(const cv::Mat& previous_dynamic);
  /// Textured pixels inside and outside the carried mask, and how many of each residual_
  /// explains (under residual_threshold_px).
  struct CarriedSplit {
    int inside = 0, explained_inside = 0, outside = 0, explained_outside = 0;
  };
  CarriedSplit splitByCarried() const;
  /// True when the fit behind `split` explains the carried (previously dynamic) pixels clearly
  /// better than the others: it follows moving objects, not the camera.
  static bool followsCarried(const CarriedSplit& split);
  /// With residual_memory > 0: adds this frame's residual vectors to the carried, decayed memory
  /// and replaces residual_ by the memory's (aperture-weighted) length. `still_weight`: see
  /// FlowMaskResult::still_camera_weight.
  void accumulateResidual(double still_weight);
  /// Sets result.median_flow_px and result.quiet_flow_share from this frame's flow.
  void flowStatistics(FlowMaskResult& result) const;
  /// Degraded result whose mask is the carried previous mask (all static when there is none).
  void useCarried(const cv::Size& input_size, FlowMaskResult& result);
  void computeTexture(const cv::Mat& grey_small);
  void applyAperture(const cv::Mat& residual_vec, cv::Mat& residual) const;
  void updatePixelGrid(const cv::Size& input_size, const cv::Size& small_size, const CameraIntrinsics& camera);

  /// What prepareFlow() hands to the compute() of its frame.
  struct PreparedFlow {
    Timestamp stamp_ns = 0;
    FlowMaskResult result;    ///< the mask's size, or why there is no flow (degraded, message)
    cv::Size small;           ///< flow resolution
    bool flow_ready = false;  ///< the flow was computed: compute() goes on from it
    double ms = 0.0;          ///< time taken [ms]
  };

  FlowMaskOptions options_;
  std::optional<PreparedFlow> prepared_;  ///< prepareFlow()'s, until compute() takes it
  cv::Ptr<cv::DISOpticalFlow> dis_;
  GlobalMotionEstimator global_motion_;
  MaskCleaner cleaner_;
  cv::Size input_size_;  ///< size of the previous frame (empty = no previous frame)
  /// For each flow-resolution pixel, its full-resolution position (undistorted when
  /// `grid_camera_` is distorted), CV_32FC2; rebuilt when the size or camera changes.
  cv::Mat grid_px_;
  cv::Size grid_input_size_;
  CameraIntrinsics grid_camera_;  ///< camera `grid_px_` was built for (invalid = raw pixels)
  // Reused buffers.
  cv::Mat grey_;
  cv::Mat prev_small_;
  cv::Mat cur_small_;
  cv::Mat flow_;
  cv::Mat flow_target_;  ///< flow-resolution position of each pixel in the previous image
  cv::Mat prev_px_;      ///< `grid_px_` sampled at `flow_target_` (NaN outside the image)
  cv::Mat residual_;
  cv::Mat small_mask_;
  cv::Mat grad_x_;
  cv::Mat grad_y_;
  cv::Mat texture_energy_;
  /// The first fit's residual_ and residual_vec_ while refitWithoutCarried() compares two fits.
  cv::Mat kept_residual_, kept_residual_vec_;
  cv::Mat txx_, txy_, tyy_;      ///< structure tensor (5x5 box) at flow resolution
  cv::Mat residual_vec_;         ///< residual vectors [full-res px], CV_32FC2
  cv::Mat depth_small_;          ///< depth at flow resolution [m] (nearest sample)
  cv::Mat predicted_px_;         ///< rigid prediction of the previous position, CV_32FC2
  cv::Mat usable_;               ///< textured cells with a rigid prediction
  cv::Mat carried_;              ///< previous final mask carried along the flow (flow resolution)
  cv::Mat memory_;               ///< residual memory [full-res px], CV_32FC2 (FlowMaskOptions::residual_memory)
  cv::Mat memory_carried_;       ///< memory_ moved along the flow into the current frame
  cv::Mat memory_gate_;          ///< pixels that move too little now to keep their memory
  bool memory_enabled_ = true;   ///< see setResidualMemoryEnabled()
  bool catching_up_ = false;     ///< see setCatchingUp()
  int preset_patch_stride_ = 4;  ///< the DIS preset's patch stride, used outside catch-up
  int preset_iterations_ = 16;   ///< the DIS preset's gradient-descent iterations, used outside catch-up
  cv::Mat fit_usable_;           ///< usable cells outside carried_ (the retried fit's samples)
  cv::Mat rigid_usable_;         ///< textured cells outside carried_ (fitRigid's samples)
  cv::Mat empty_;
  bool last_flow_valid_ = false;
  cv::Mat textured_;  ///< CV_8UC1 at flow resolution, 255 = enough texture to trust the flow
};

}  // namespace mask
}  // namespace dypho
