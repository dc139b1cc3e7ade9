#include "dypho/mask/flow_motion_masker.h"

#include "dypho/mask/ego_motion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "mask_internal.h"

namespace dypho {
namespace mask {

using internal::Clock;
using internal::msSince;

namespace {

std::string sizeString(const cv::Size& s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

GlobalMotionSettings globalMotionSettings(const FlowMaskOptions& o) {
  GlobalMotionSettings s;
  s.sample_step = std::max(1, static_cast<int>(std::lround(o.sample_step_px * o.flow_scale)));
  s.ransac_threshold_px = o.ransac_threshold_px;  // correspondences are in full-res pixels
  s.max_iterations = o.ransac_max_iterations;
  s.min_inlier_ratio = o.min_inlier_ratio;
  return s;
}

MaskCleanerSettings cleanerSettings(const FlowMaskOptions& o) {
  MaskCleanerSettings s;
  // Lengths scale with flow_scale, areas with its square; a non-zero length stays >= 1 flow px.
  auto length = [&](int full_px) {
    return full_px > 0 ? std::max(1, static_cast<int>(std::lround(full_px * o.flow_scale))) : 0;
  };
  s.open_radius_px = length(o.open_radius_px);
  s.dilate_radius_px = length(o.dilate_px);
  s.min_region_area_px = static_cast<int>(std::lround(o.min_region_area_px * o.flow_scale * o.flow_scale));
  return s;
}

}  // namespace

FlowMotionMasker::FlowMotionMasker(const FlowMaskOptions& options)
    : options_((options.validate(), options)),
      dis_(cv::DISOpticalFlow::create(options.ultrafast ? cv::DISOpticalFlow::PRESET_ULTRAFAST
                                                        : cv::DISOpticalFlow::PRESET_FAST)),
      global_motion_(globalMotionSettings(options)),
      cleaner_(cleanerSettings(options)) {
  // The presets stop their coarse-to-fine pyramid at scale 2 (1/4 of the input they get). We hand
  // DIS an image already reduced by flow_scale, so let it refine down to that image's full
  // resolution; otherwise the flow would be 4x coarser than flow_scale says.
  dis_->setFinestScale(0);
  dis_->setVariationalRefinementIterations(options.dis_refinement_iterations);
  preset_patch_stride_ = dis_->getPatchStride();
  preset_iterations_ = dis_->getGradientDescentIterations();
}

FlowMotionMasker::~FlowMotionMasker() = default;

void FlowMotionMasker::reset() {
  prepared_.reset();
  input_size_ = cv::Size();
  memory_.release();
  last_flow_valid_ = false;
}

bool FlowMotionMasker::checkInput(const RgbdFrame& frame, FlowMaskResult& result) const {
  std::string problem;
  const cv::Size size = frame.bgr.size();
  if (frame.bgr.empty()) {
    problem = "empty colour image (check the rgb topic / image loader)";
  } else if (frame.bgr.type() != CV_8UC3 && frame.bgr.type() != CV_8UC1) {
    problem = "colour image must be CV_8UC3 (bgr8) or CV_8UC1 (mono8), got type " + std::to_string(frame.bgr.type());
  } else if (!frame.depth_m.empty() && frame.depth_m.size() != size) {
    problem = "depth " + sizeString(frame.depth_m.size()) + " does not match colour " + sizeString(size) +
              " (register depth to colour)";
  } else if (frame.camera.valid() && cv::Size(frame.camera.width, frame.camera.height) != size) {
    problem = "camera intrinsics are for " + sizeString(cv::Size(frame.camera.width, frame.camera.height)) +
              " but the colour image is " + sizeString(size);
  } else if (std::lround(size.width * options_.flow_scale) < 8 || std::lround(size.height * options_.flow_scale) < 8) {
    problem = "image " + sizeString(size) + " is too small for flow_scale " + std::to_string(options_.flow_scale) +
              " (needs >= 8 px at flow resolution)";
  }
  if (problem.empty()) return true;
  result.degraded = true;
  result.message = "bad input: " + problem;
  if (!frame.bgr.empty()) result.mask = cv::Mat::zeros(size, CV_8UC1);
  return false;
}

void FlowMotionMasker::prepareFlow(const RgbdFrame& frame) {
  const auto t0 = Clock::now();
  last_flow_valid_ = false;
  PreparedFlow p;
  p.stamp_ns = frame.stamp_ns;
  if (checkInput(frame, p.result)) {
    const cv::Size size = frame.bgr.size();
    p.result.mask = cv::Mat::zeros(size, CV_8UC1);
    p.small = reduceGrey(frame.bgr);
    if (continueHistory(size, p.result)) {
      computeFlow(p.result);
      p.flow_ready = true;
    }
  }
  p.ms = msSince(t0);
  prepared_ = std::move(p);
}

FlowMaskResult FlowMotionMasker::compute(const RgbdFrame& frame, const std::optional<Eigen::Isometry3d>& T_prev_cur,
                                         const cv::Mat& previous_dynamic, PoseFitUse fit) {
  if (!prepared_ || prepared_->stamp_ns != frame.stamp_ns) prepareFlow(frame);
  const auto t0 = Clock::now();  // the prepared part's time is prepared.ms
  PreparedFlow prepared = std::move(*prepared_);
  prepared_.reset();
  FlowMaskResult result = std::move(prepared.result);
  const auto finished = [&] { result.total_ms = prepared.ms + msSince(t0); };
  if (!prepared.flow_ready) {
    finished();
    return result;
  }
  const cv::Size size = frame.bgr.size();
  const cv::Size small = prepared.small;
  computeCorrespondences(size, small, frame.camera);
  carryPrevious(previous_dynamic);
  if (!fitEgoMotion(frame, small, T_prev_cur, fit, result)) {
    finished();
    return result;
  }
  weighStillCamera(result);
  accumulateResidual(result.still_camera_weight);
  thresholdResidual(size, result);
  finishMask(size, result);
  finished();
  return result;
}

cv::Size FlowMotionMasker::reduceGrey(const cv::Mat& bgr) {
  // grey_ is only written by cvtColor; a mono8 input is read in place (never written).
  if (bgr.channels() == 3) cv::cvtColor(bgr, grey_, cv::COLOR_BGR2GRAY);
  const cv::Mat& grey = bgr.channels() == 3 ? grey_ : bgr;
  const cv::Size size = bgr.size();
  const cv::Size small(static_cast<int>(std::lround(size.width * options_.flow_scale)),
                       static_cast<int>(std::lround(size.height * options_.flow_scale)));
  if (small == size) {
    grey.copyTo(cur_small_);
  } else {
    cv::resize(grey, cur_small_, small, 0, 0, cv::INTER_AREA);
  }
  return small;
}

bool FlowMotionMasker::continueHistory(const cv::Size& input_size, FlowMaskResult& result) {
  const bool have_previous = !input_size_.empty() && input_size_ == input_size;
  if (have_previous) return true;
  if (!input_size_.empty()) {
    result.degraded = true;
    result.message = "image size changed from " + sizeString(input_size_) + " to " + sizeString(input_size) +
                     ": flow history reset, mask empty for this frame";
  } else {
    result.message = "first frame: no previous image, mask empty";
  }
  input_size_ = input_size;
  memory_.release();
  std::swap(prev_small_, cur_small_);
  return false;
}

void FlowMotionMasker::computeFlow(FlowMaskResult& result) {
  // Backward flow: defined on current pixels, pointing to where they were in the previous image,
  // so that the mask lies on the objects' current positions.
  const auto t_flow = Clock::now();
  dis_->setVariationalRefinementIterations(catching_up_ ? 0 : options_.dis_refinement_iterations);
  dis_->setPatchStride(catching_up_ ? options_.dis_catch_up_patch_stride : preset_patch_stride_);
  dis_->setGradientDescentIterations(catching_up_ ? options_.dis_catch_up_iterations : preset_iterations_);
  dis_->calc(cur_small_, prev_small_, flow_);
  result.flow_ms = msSince(t_flow);
  last_flow_valid_ = true;
  computeTexture(cur_small_);
  std::swap(prev_small_, cur_small_);
}

void FlowMotionMasker::computeCorrespondences(const cv::Size& input_size, const cv::Size& small,
                                              const CameraIntrinsics& camera) {
  // Correspondences in full-resolution (undistorted) pixels: current = the pixel grid, previous =
  // the grid sampled where the flow points (NaN when that is outside the previous image).
  updatePixelGrid(input_size, small, camera);
  flow_target_.create(flow_.size(), CV_32FC2);
  for (int y = 0; y < flow_.rows; ++y) {
    const cv::Vec2f* f = flow_.ptr<cv::Vec2f>(y);
    cv::Vec2f* t = flow_target_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < flow_.cols; ++x) t[x] = cv::Vec2f(x + f[x][0], y + f[x][1]);
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::remap(grid_px_, prev_px_, flow_target_, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar(nan, nan));
}

bool FlowMotionMasker::fitEgoMotion(const RgbdFrame& frame, const cv::Size& small,
                                    const std::optional<Eigen::Isometry3d>& T_prev_cur, PoseFitUse fit_use,
                                    FlowMaskResult& result) {
  // The fit takes every usable sample, first with the rigid prediction (pose + depth), then as a
  // plain homography; then refitWithoutCarried() may replace it.
  const bool has_depth = frame.camera.valid() && !frame.depth_m.empty();
  std::optional<Eigen::Isometry3d> T_used = has_depth ? T_prev_cur : std::nullopt;
  // Depth at flow resolution, once, for the fit and the rigid prediction.
  if (has_depth && T_prev_cur) cv::resize(frame.depth_m, depth_small_, small, 0, 0, cv::INTER_NEAREST);
  if (has_depth && T_prev_cur && fit_use != PoseFitUse::kNone) {
    result.T_prev_cur_fitted = fitRigid(frame, small, *T_prev_cur);
    if (fit_use == PoseFitUse::kEgoMotion) T_used = result.T_prev_cur_fitted;
  }
  const bool with_pose = T_used.has_value();
  if (with_pose) predictFromPose(frame, *T_used);
  bool from_pose = false;
  GlobalMotionFit fit = fitOnce(with_pose, false, from_pose);
  if (fit.ok) computeResidual(fit, from_pose);
  if (!carried_.empty() && cv::countNonZero(carried_) > 0) refitWithoutCarried(with_pose, fit, from_pose, result);
  result.inlier_ratio = fit.inlierRatio();
  if (!fit.ok) {
    result.message = "global motion not found: " + fit.message;
    memory_.release();  // no residual this frame: the slow-motion evidence starts again
    useCarried(frame.bgr.size(), result);
    return false;
  }
  result.H_prev_cur = fit.H_prev_cur;
  result.ego_motion_from_pose = from_pose;
  if (from_pose) result.T_prev_cur = T_used;
  return true;
}

void FlowMotionMasker::refitWithoutCarried(bool with_pose, GlobalMotionFit& fit, bool& from_pose,
                                           FlowMaskResult& result) {
  // The fit on every sample is tried again without the previous frame's dynamic pixels when it
  // failed (people fill the view), when it follows them (their pixels agree with it better than
  // the rest: it locked onto a group of people), or, with several motions in view, when the fit
  // without them explains clearly more of the rest (refit_without_previous_margin): with two
  // groups of people walking apart and the previous mask on one of them, the first fit settles on
  // the other or between them, and neither test above sees it. Only then: the exclusion feeds the
  // mask back into its own fit, which must not happen on frames that fit anyway (a region masked
  // once would stay masked).
  const CarriedSplit first = fit.ok ? splitByCarried() : CarriedSplit();
  const bool follows = fit.ok && followsCarried(first);
  const double margin = options_.refit_without_previous_margin;
  const bool compare = fit.ok && !follows && margin > 0.0;
  if (fit.ok && !follows && !compare) return;
  bool refit_from_pose = false;
  const GlobalMotionFit refit = fitOnce(with_pose, true, refit_from_pose);
  if (!refit.ok) return;  // residual_ is still the first fit's
  if (compare) {
    std::swap(residual_, kept_residual_);
    std::swap(residual_vec_, kept_residual_vec_);
  }
  computeResidual(refit, refit_from_pose);
  const CarriedSplit split = compare ? splitByCarried() : CarriedSplit();
  if (compare && split.explained_outside <= first.explained_outside + margin * split.outside) {
    std::swap(residual_, kept_residual_);  // the first fit stays, with its residual
    std::swap(residual_vec_, kept_residual_vec_);
    return;
  }
  fit = refit;
  from_pose = refit_from_pose;
  result.fit_excluded_previous_mask = true;
}

/// Share of the fit's samples the fitted motion must explain beyond the prediction to replace it.
constexpr double kFitMustExplainMore = 0.1;

Eigen::Isometry3d FlowMotionMasker::fitRigid(const RgbdFrame& frame, const cv::Size& small,
                                             const Eigen::Isometry3d& T_prev_cur) {
  // The camera's motion between the two images, fitted to the flow of the static scene (textured
  // cells with depth, outside the previous frame's movers) from the prediction. A prediction made
  // a few frames ahead (a live graph's mask runs before tracking has the previous frame) misses
  // the hand's jerks; its translation error leaves depth-dependent residuals that no homography
  // absorbs, on the whole static view.
  if (textured_.empty()) {
    rigid_usable_ = cv::Mat(small, CV_8UC1, cv::Scalar(255));
  } else {
    textured_.copyTo(rigid_usable_);
  }
  if (!carried_.empty()) rigid_usable_.setTo(0, carried_);
  // In catch-up mode on every third cell across and down instead of every second: still over a
  // thousand samples for six unknowns, at less than half the cost (the live mask thread's
  // largest cost after the flow: 10 % of its samples).
  constexpr int kCatchUpRigidSampleStride = 3;
  RigidFitSettings rigid;
  if (catching_up_) rigid.sample_stride = kCatchUpRigidSampleStride;
  const RigidFit fit = fitRigidMotion(grid_px_, depth_small_, prev_px_, rigid_usable_, frame.camera, T_prev_cur, rigid);
  if (!fit.ok) return T_prev_cur;
  // The fit replaces the prediction only when it explains clearly more cells: people in view,
  // most of all of a still camera, can drag a fit a little along a direction the static scene
  // hardly constrains, and gain it a few per cent of the cells (their own). A stale prediction
  // explains a small share of what the fit does.
  const double threshold = options_.residual_threshold_px;
  const int fitted =
      countRigidInliers(grid_px_, depth_small_, prev_px_, rigid_usable_, frame.camera, fit.T_prev_cur, threshold, 1);
  const int predicted =
      countRigidInliers(grid_px_, depth_small_, prev_px_, rigid_usable_, frame.camera, T_prev_cur, threshold, 1);
  const double margin = kFitMustExplainMore * cv::countNonZero(rigid_usable_);
  return fitted >= predicted + margin ? fit.T_prev_cur : T_prev_cur;
}

void FlowMotionMasker::predictFromPose(const RgbdFrame& frame, const Eigen::Isometry3d& T_prev_cur) {
  predictRigidPrevious(grid_px_, depth_small_, frame.camera, T_prev_cur, predicted_px_);
  cv::Mat channels[2];
  cv::split(predicted_px_, channels);
  cv::compare(channels[0], channels[0], usable_, cv::CMP_EQ);  // NaN != NaN
  if (!textured_.empty()) usable_ &= textured_;
}

GlobalMotionFit FlowMotionMasker::fitOnce(bool with_pose, bool exclude_previous, bool& from_pose) {
  // Ego-motion from depth + predicted pose: a homography between predicted and measured previous
  // positions absorbs the prediction's rotation error (exact for a pure rotation).
  GlobalMotionFit fit;
  for (const bool pose_attempt : {true, false}) {
    if (pose_attempt && !with_pose) continue;
    const cv::Mat& usable = pose_attempt ? usable_ : textured_;
    if (exclude_previous) {
      cv::bitwise_not(carried_, fit_usable_);
      if (!usable.empty()) fit_usable_ &= usable;
    }
    fit =
        global_motion_.fit(pose_attempt ? predicted_px_ : grid_px_, prev_px_, exclude_previous ? fit_usable_ : usable);
    from_pose = pose_attempt;
    if (fit.ok) break;
  }
  return fit;
}

void FlowMotionMasker::computeResidual(const GlobalMotionFit& fit, bool from_pose) {
  computeResidualMagnitude(from_pose ? predicted_px_ : grid_px_, prev_px_, fit.H_prev_cur, residual_, &residual_vec_);
  if (options_.aperture_aware && !txx_.empty()) applyAperture(residual_vec_, residual_);
}

void FlowMotionMasker::weighStillCamera(FlowMaskResult& result) const {
  // Full weight below kStillFlowPx of median flow, none from kMovingFlowPx on (full-res px).
  constexpr double kStillFlowPx = 2.0, kMovingFlowPx = 6.0;
  flowStatistics(result);
  result.still_camera_weight =
      std::clamp((kMovingFlowPx - result.median_flow_px) / (kMovingFlowPx - kStillFlowPx), 0.0, 1.0);
}

void FlowMotionMasker::thresholdResidual(const cv::Size& input_size, FlowMaskResult& result) {
  cv::threshold(residual_, residual_, options_.residual_threshold_px, 255, cv::THRESH_BINARY);
  residual_.convertTo(small_mask_, CV_8U);
  if (!textured_.empty()) small_mask_ &= textured_;
  cv::resize(small_mask_, result.raw_flow_mask, input_size, 0, 0, cv::INTER_NEAREST);
}

void FlowMotionMasker::updatePixelGrid(const cv::Size& input_size, const cv::Size& small,
                                       const CameraIntrinsics& frame_camera) {
  const CameraIntrinsics camera = frame_camera.valid() && frame_camera.distorted() ? frame_camera : CameraIntrinsics();
  if (!grid_px_.empty() && grid_px_.size() == small && grid_input_size_ == input_size &&
      sameCamera(camera, grid_camera_)) {
    return;
  }
  grid_input_size_ = input_size;
  grid_camera_ = camera;
  // Centre of reduced pixel (i, j) in full-resolution pixels (cv::resize convention).
  const double sx = static_cast<double>(input_size.width) / small.width;
  const double sy = static_cast<double>(input_size.height) / small.height;
  grid_px_.create(small, CV_32FC2);
  for (int y = 0; y < small.height; ++y) {
    cv::Vec2f* g = grid_px_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < small.width; ++x) {
      g[x] = cv::Vec2f(static_cast<float>((x + 0.5) * sx - 0.5), static_cast<float>((y + 0.5) * sy - 0.5));
    }
  }
  if (!camera.valid()) return;
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const cv::Mat D(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
  cv::Mat points = grid_px_.reshape(2, small.area());
  cv::Mat undistorted;
  cv::undistortPoints(points, undistorted, K, D, cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-4));
  undistorted.reshape(2, small.height).copyTo(grid_px_);
}

void FlowMotionMasker::computeTexture(const cv::Mat& grey_small) {
  if (options_.min_texture_gradient <= 0.0) {
    textured_.release();
    return;
  }
  // Sobel 3x3 scaled by 1/8 gives the gradient in grey levels per pixel. The structure tensor
  // [txx txy; txy tyy] over 5x5 is kept for the aperture-aware residual.
  cv::Sobel(grey_small, grad_x_, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(grey_small, grad_y_, CV_32F, 0, 1, 3, 1.0 / 8.0);
  cv::multiply(grad_x_, grad_y_, txy_);
  cv::multiply(grad_x_, grad_x_, txx_);
  cv::multiply(grad_y_, grad_y_, tyy_);
  cv::boxFilter(txx_, txx_, -1, cv::Size(5, 5));
  cv::boxFilter(tyy_, tyy_, -1, cv::Size(5, 5));
  cv::boxFilter(txy_, txy_, -1, cv::Size(5, 5));
  cv::add(txx_, tyy_, texture_energy_);
  const double threshold = options_.min_texture_gradient * options_.min_texture_gradient;
  cv::compare(texture_energy_, threshold, textured_, cv::CMP_GE);
}

void FlowMotionMasker::applyAperture(const cv::Mat& residual_vec, cv::Mat& residual) const {
  // Along an edge only the normal flow is measured; the flow along it is interpolated and its
  // error is no evidence of motion. The residual r is weighted by the structure tensor S:
  // |r|_eff = sqrt(r^T S r / lambda_max(S)) = |r| on corners, |r . n| (normal part) on edges.
  for (int y = 0; y < residual.rows; ++y) {
    const cv::Vec2f* r = residual_vec.ptr<cv::Vec2f>(y);
    const float* a = txx_.ptr<float>(y);
    const float* b = txy_.ptr<float>(y);
    const float* c = tyy_.ptr<float>(y);
    float* out = residual.ptr<float>(y);
    for (int x = 0; x < residual.cols; ++x) {
      const float h = 0.5f * (a[x] - c[x]);
      const float l_max = 0.5f * (a[x] + c[x]) + std::sqrt(h * h + b[x] * b[x]);
      if (!(l_max > 1e-6f)) continue;  // flat: left as is (the texture mask drops it)
      const float dx = r[x][0], dy = r[x][1];
      const float q = (a[x] * dx * dx + 2.f * b[x] * dx * dy + c[x] * dy * dy) / l_max;
      out[x] = std::sqrt(std::max(0.f, q));
    }
  }
}

void FlowMotionMasker::carryPrevious(const cv::Mat& previous_dynamic) {
  if (previous_dynamic.empty() || previous_dynamic.type() != CV_8UC1 || previous_dynamic.size() != input_size_) {
    carried_.release();
    return;
  }
  cv::resize(previous_dynamic, carried_, flow_.size(), 0, 0, cv::INTER_AREA);
  cv::threshold(carried_, carried_, 127, 255, cv::THRESH_BINARY);
  // Backward flow: each current pixel reads the previous mask where it came from.
  cv::remap(carried_, carried_, flow_target_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
}

void FlowMotionMasker::setResidualMemoryEnabled(bool enabled) {
  if (!enabled) memory_.release();
  memory_enabled_ = enabled;
}

void FlowMotionMasker::accumulateResidual(double still_weight) {
  if (options_.residual_memory <= 0.0 || !memory_enabled_) return;
  // memory_ holds the residual vectors of the earlier frames, each pixel's own: carried along the
  // backward flow like the previous mask, decayed, plus this frame's residual. A person moving
  // 1 px per frame stays under a 2 px threshold frame to frame, but not in the memory
  // (steady state residual / (1 - memory)), while zero-mean noise grows only by
  // 1 / sqrt(1 - memory^2).
  // The memory also adds up what the ego-motion model gets wrong the same way frame after frame
  // (rolling shutter, colour/depth time offset, parallax under fast motion), which grows with the
  // camera's own image motion: it is weighted by how still the camera is.
  const double memory = options_.residual_memory * still_weight;
  if (memory_.empty() || memory_.size() != residual_vec_.size() || memory <= 0.0) {
    residual_vec_.copyTo(memory_);
  } else {
    cv::remap(memory_, memory_carried_, flow_target_, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar(0, 0));
    // Only a pixel that moves enough now to be found by the sum keeps its memory: its residual
    // must reach (1 - memory) * threshold, the level whose steady-state sum reaches the
    // threshold. Noise below that level is not added up, and the background uncovered behind a
    // person (its flow points into the person, whose memory it would inherit) starts afresh.
    cv::compare(residual_, (1.0 - memory) * options_.residual_threshold_px, memory_gate_, cv::CMP_LT);
    memory_carried_.setTo(cv::Scalar(0, 0), memory_gate_);
    cv::addWeighted(memory_carried_, memory, residual_vec_, 1.0, 0.0, memory_);
  }
  if (options_.aperture_aware && !txx_.empty()) {
    applyAperture(memory_, residual_);
  } else {
    std::vector<cv::Mat> xy;
    cv::split(memory_, xy);
    cv::magnitude(xy[0], xy[1], residual_);
  }
}

void FlowMotionMasker::flowStatistics(FlowMaskResult& result) const {
  // Over a sparse grid of the textured pixels: the median flow length [full-res px], the share of
  // samples that move less than kQuietFlowPx, and the median flow length of the samples the
  // ego-motion explains (residual under the threshold: the static scene, without the movers).
  constexpr float kQuietFlowPx = 0.5f;
  const float to_full = static_cast<float>(1.0 / options_.flow_scale);
  const float threshold = static_cast<float>(options_.residual_threshold_px);
  std::vector<float> lengths, static_lengths;
  lengths.reserve(static_cast<size_t>(flow_.total() / 16 + 1));
  static_lengths.reserve(lengths.capacity());
  int quiet = 0;
  for (int y = 2; y < flow_.rows; y += 4) {
    const cv::Vec2f* f = flow_.ptr<cv::Vec2f>(y);
    const uchar* t = textured_.empty() ? nullptr : textured_.ptr<uchar>(y);
    const float* r = residual_.ptr<float>(y);
    for (int x = 2; x < flow_.cols; x += 4) {
      if (t != nullptr && t[x] == 0) continue;
      lengths.push_back(std::hypot(f[x][0], f[x][1]) * to_full);
      quiet += lengths.back() < kQuietFlowPx;
      if (r[x] < threshold) static_lengths.push_back(lengths.back());
    }
  }
  if (lengths.empty()) return;
  const auto median = [](std::vector<float>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return static_cast<double>(v[v.size() / 2]);
  };
  result.median_flow_px = median(lengths);
  result.quiet_flow_share = static_cast<double>(quiet) / static_cast<double>(lengths.size());
  if (!static_lengths.empty()) result.static_median_flow_px = median(static_lengths);
}

FlowMotionMasker::CarriedSplit FlowMotionMasker::splitByCarried() const {
  CarriedSplit split;
  const float threshold = static_cast<float>(options_.residual_threshold_px);
  for (int y = 0; y < residual_.rows; ++y) {
    const float* r = residual_.ptr<float>(y);
    const uchar* c = carried_.ptr<uchar>(y);
    const uchar* t = textured_.empty() ? nullptr : textured_.ptr<uchar>(y);
    for (int x = 0; x < residual_.cols; ++x) {
      if (t != nullptr && t[x] == 0) continue;
      const bool explained = r[x] < threshold;
      if (c[x] != 0) {
        ++split.inside;
        split.explained_inside += explained;
      } else {
        ++split.outside;
        split.explained_outside += explained;
      }
    }
  }
  return split;
}

bool FlowMotionMasker::followsCarried(const CarriedSplit& s) {
  // Share of textured pixels the fit explains (residual below the threshold), inside and outside
  // the carried mask. A fit on the static scene explains the outside and not the moving inside;
  // a fit on a group of people does the opposite.
  constexpr int kMinPixels = 20;     // flow pixels on each side for the shares to mean something
  constexpr double kMinLead = 0.25;  // the inside must lead clearly (noise moves both shares)
  if (s.inside < kMinPixels || s.outside < kMinPixels) return false;
  return static_cast<double>(s.explained_inside) / s.inside >
         static_cast<double>(s.explained_outside) / s.outside + kMinLead;
}

void FlowMotionMasker::useCarried(const cv::Size& size, FlowMaskResult& result) {
  result.degraded = true;
  if (carried_.empty() || cv::countNonZero(carried_) == 0) {  // nothing known: all static
    result.motion_unknown = true;
    return;
  }
  // The previous mask already holds the margin, which the caller adds again: take it off first
  // so that a run of degraded frames does not grow the mask by a margin per frame.
  const int r = cleanerSettings(options_).dilate_radius_px;
  if (r > 0) {
    cv::erode(carried_, small_mask_, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
  } else {
    carried_.copyTo(small_mask_);
  }
  cv::resize(small_mask_, result.mask, size, 0, 0, cv::INTER_LINEAR);
  cv::threshold(result.mask, result.mask, 127, 255, cv::THRESH_BINARY);
  result.masked_fraction = static_cast<double>(cv::countNonZero(result.mask)) / static_cast<double>(size.area());
  result.message += "; the previous mask carried along the flow is used";
}

void FlowMotionMasker::finishMask(const cv::Size& size, FlowMaskResult& result) {
  cleaner_.apply(small_mask_);
  // Linear upsampling then a mid-level threshold gives boundaries without blocky steps.
  cv::resize(small_mask_, result.mask, size, 0, 0, cv::INTER_LINEAR);
  cv::threshold(result.mask, result.mask, 127, 255, cv::THRESH_BINARY);
  result.masked_fraction = static_cast<double>(cv::countNonZero(result.mask)) / static_cast<double>(size.area());
  if (result.masked_fraction > options_.max_masked_fraction) {
    result.degraded = true;
    result.message = "masked fraction " + std::to_string(result.masked_fraction) + " exceeds max_masked_fraction " +
                     std::to_string(options_.max_masked_fraction) + ": global motion model considered wrong";
    result.mask.setTo(0);
    result.masked_fraction = 0.0;
    useCarried(size, result);
  }
}

}  // namespace mask
}  // namespace dypho
