#pragma once
/// \file background_model.h
/// Prior static-background depth model of the paper (Sec. "Dynamic Process", optimized mask):
///
///   B_i = (1 - tau - rho) B_{i-1} + tau R_d(G, T_pred) + rho D_i (1 - M_raw)
///
/// and the neighbourhood depth-consistency mask derived from it. Our reading, per pixel:
///  - B_{i-1} is first carried into the current view (`warpDepthForward`): every background pixel
///    is back-projected with its own depth in the previous camera, moved with T_cur_prev =
///    T_prev_cur^-1 and splatted into the current image with a z-buffer (nearest wins); one-pixel
///    holes and cracks inside the splatted region (its 5x5 closing) get the nearest 5x5 depth. Without a pose the
///    camera is taken as still (B_{i-1} is used as is).
///  - Terms without a value (B with no value yet, no rendered depth, D invalid or raw-dynamic) are
///    left out and the remaining weights renormalised; so B starts as D_1 minus the raw mask (the
///    paper's initialisation) and the rendered term is simply absent until mapping provides it.
///  - The consistency test uses the prior Q = the B_{i-1}/R_d part (D_i does not vote for itself)
///    and is one-sided: a neighbour q agrees with pixel x unless D_i(q) < Q(x) - sigma_m, i.e.
///    only something IN FRONT of the background is dynamic. A pixel is dynamic when at most n_m
///    of its valid neighbours agree (paper: static when more than n_m agree); with n_m or fewer
///    valid neighbours it is undecided (not dynamic here; the raw masks decide).
///  - The carried B is only as good as the predicted pose and the depth's registration to it: on a
///    fast turn a depth edge lands a few pixels off (the depth is not read out at the colour
///    image's instant, the prediction has its own error), and the static surface in front of the
///    edge would be "in front of the background". `retest` therefore compares each pixel with the
///    nearest background depth within a radius that grows with the frame's image motion as the
///    flow measured it (BackgroundOptions::motion_tolerance, `nearestWithin`); a person standing in
///    front of a wall is still in front of all of it. The flow's measure, not the predicted pose's:
///    people who drag the tracked pose of a still camera must not loosen the test.
///  - Where D_i is farther than Q + sigma_m (background revealed behind an object that left, or a
///    person absorbed into B before it moved), B_i takes D_i directly instead of blending slowly.
///  - D_i enters only where neither the raw mask nor this frame's consistency mask is dynamic.

#include <optional>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"
#include "dypho/mask/dynamic_mask_options.h"

namespace dypho {
namespace mask {

/// Moves a depth image (CV_32FC1 [m], 0 = none) of the previous camera into the current one:
/// forward splat with z-buffer, then filling of holes inside the splatted region (file comment). `camera` are the
/// intrinsics at the images' resolution (distortion ignored).
void warpDepthForward(const cv::Mat& depth_prev_m, const CameraIntrinsics& camera, const Eigen::Isometry3d& T_cur_prev,
                      cv::Mat& depth_cur_m);

/// Drops each 8-connected region of `raw_dynamic` (CV_8UC1, in place) that the background
/// explains: at least `min_consistent_share` of its pixels with both depths valid have
/// |depth - background| < sigma_m, at least `min_checked_share` of its pixels have both, and it
/// touches no pixel of `consistency_dynamic`. Removes flow false positives on the static scene.
void vetoRegionsOnBackground(const cv::Mat& background_m, const cv::Mat& depth_m, const cv::Mat& consistency_dynamic,
                             double sigma_m, double min_consistent_share, double min_checked_share,
                             cv::Mat& raw_dynamic);

/// Clears from `consistency_dynamic` (CV_8UC1, in place) each 8-connected region of which less
/// than `min_support_share` of the pixels are also in `raw_dynamic` (the flow or network mask,
/// same size; empty = supports nothing), and sets exactly the cleared pixels in `cleared`
/// (CV_8UC1, 255 = cleared).
void dropUnsupportedRegions(const cv::Mat& raw_dynamic, double min_support_share, cv::Mat& consistency_dynamic,
                            cv::Mat& cleared);

/// `nearest_m` = the minimum of the valid (> 0) depths of `depth_m` within a disc of `radius_px`
/// around each pixel, at the pixels where `depth_m` itself is valid (0 elsewhere). radius 0 copies.
void nearestWithin(const cv::Mat& depth_m, int radius_px, cv::Mat& nearest_m);

/// One-sided neighbourhood consistency. `dynamic` (CV_8UC1, 255 = dynamic) for each pixel x with
/// background_m(x) > 0: among the window x window neighbours q with depth_m(q) > 0, count those
/// with depth_m(q) >= background_m(x) - sigma_m; dynamic when there are more than `min_agreeing`
/// valid neighbours and at most `min_agreeing` agree. Inputs CV_32FC1 of equal size.
/// Exact count, computed fast: windows whose valid depths all agree (min over the window) or
/// none agree (max) are decided from morphology and box filters; only the rest are counted.
void depthConsistencyMask(const cv::Mat& background_m, const cv::Mat& depth_m, double sigma_m, int window,
                          int min_agreeing, cv::Mat& dynamic);

/// The recursive background model at one (reduced) resolution. Not thread-safe.
class BackgroundModel {
 public:
  explicit BackgroundModel(const BackgroundOptions& options);

  /// One step = test() then update() with `raw_dynamic | dynamic` as the exclusion. All images at
  /// the model resolution: `depth_m` CV_32FC1 [m] (0/NaN = none), `raw_dynamic` CV_8UC1 (non-zero
  /// = dynamic by the raw masks), `rendered_depth_m` CV_32FC1 or empty; `camera` the intrinsics at
  /// this resolution; `T_prev_cur` the predicted relative pose (nullopt = camera still);
  /// `image_motion_px` the frame's measured image motion at this resolution (see retest()). Writes
  /// the consistency mask (CV_8UC1, 255 = dynamic) and updates B. A size change restarts the model.
  void process(const cv::Mat& depth_m, const cv::Mat& raw_dynamic, const cv::Mat& rendered_depth_m,
               const CameraIntrinsics& camera, const std::optional<Eigen::Isometry3d>& T_prev_cur, cv::Mat& dynamic,
               double image_motion_px = 0.0);

  /// First half of a step: carries B_{i-1} into the current view, forms the prior Q (see prior())
  /// and writes the consistency mask of `depth_m` against it (CV_8UC1, 255 = dynamic). Arguments
  /// as for process(). B itself is not changed until update().
  void test(const cv::Mat& depth_m, const cv::Mat& rendered_depth_m, const CameraIntrinsics& camera,
            const std::optional<Eigen::Isometry3d>& T_prev_cur, cv::Mat& dynamic);

  /// Between test() and update(), once the frame's image motion is known [px at this resolution,
  /// e.g. the flow's median]: the consistency mask again, each pixel against the nearest prior
  /// depth within BackgroundOptions::motion_tolerance times that motion (file comment). Returns
  /// false and leaves `dynamic` as test() wrote it when the radius rounds to 0.
  bool retest(const cv::Mat& depth_m, double image_motion_px, cv::Mat& dynamic);

  /// Second half: B_i from the carried B_{i-1}, the rendered depth and D_i where `excluded` (CV_8UC1,
  /// non-zero = do not learn this pixel: raw, consistency or grown dynamic) is zero. Must follow
  /// test() on the same `depth_m` / `rendered_depth_m`.
  void update(const cv::Mat& depth_m, const cv::Mat& rendered_depth_m, const cv::Mat& excluded);

  /// B_i after the last process(), CV_32FC1 [m], 0 = no value; empty before the first call.
  const cv::Mat& background() const { return background_; }
  /// The prior Q (warped B_{i-1} with the rendered term) the last consistency test used,
  /// CV_32FC1 [m], 0 = none.
  const cv::Mat& prior() const { return prior_; }
  /// Forgets B.
  void reset() { background_.release(); }
  /// B = D outright on the non-zero pixels of `pixels` where D is valid (B's own value there was
  /// found wrong); `depth_m` and `pixels` at background resolution.
  void relearn(const cv::Mat& depth_m, const cv::Mat& pixels);

 private:
  BackgroundOptions options_;
  cv::Mat background_;
  cv::Mat prior_;
  cv::Mat tested_;  ///< prior_ as the consistency test reads it (nearestWithin the motion's tolerance)
  cv::Mat warped_;
  bool warped_valid_ = false;  ///< test() carried B into warped_ (else B is used as is)
  cv::Mat excluded_;
};

}  // namespace mask
}  // namespace dypho
