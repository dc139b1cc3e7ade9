#pragma once
/// \file view_evaluation.h
/// The map as a user sees it: the map rendered at the estimated pose of every Nth frame of a
/// sequence (not only at the keyframes it was trained on), scored on the static pixels of each
/// frame (the system's dynamic mask, dilated, left out):
///  - PSNR [dB] and SSIM of the colour (holes count: an unrendered pixel is black);
///  - depth L1 [m] where both the input and the render have a depth;
///  - coverage: the share of static pixels where the map's accumulated opacity is >= 0.5.
/// Frames that became keyframes and frames that never did (novel views) are summarised apart.

#include <cstddef>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/mapping/map_renderer.h"

namespace dypho::mapping {

/// Settings of the view evaluation.
struct ViewEvaluationOptions {
  /// Every Nth frame of the sequence is rendered and scored [count]; default 10, >= 1.
  int every_nth_frame = 10;
  /// The dynamic mask is grown by this radius before scoring, so that a mover's rim, which the
  /// mask may miss by a few pixels, does not count against the map [px]; default 5, >= 0.
  int mask_dilation_px = 5;
  /// A pixel is covered where the rendered opacity is at least this; default 0.5, in (0, 1].
  float coverage_min_alpha = 0.5f;

  /// Throws std::invalid_argument naming the bad field and its accepted range.
  void validate() const;
};

/// One scored view.
struct ViewScore {
  Timestamp stamp_ns = 0;
  bool keyframe = false;          ///< the frame became a keyframe (the map was trained on it)
  std::size_t static_pixels = 0;  ///< pixels scored (static after dilation)
  double psnr_db = 0.0;           ///< PSNR of the colour over static pixels [dB]
  double ssim = 0.0;              ///< mean SSIM over static pixels (11-tap Gaussian, sigma 1.5)
  double depth_l1_m = 0.0;        ///< mean |rendered - input| depth where both exist [m]
  double coverage = 0.0;          ///< share of static pixels with opacity >= coverage_min_alpha
};

/// Means over a set of views.
struct ViewSummary {
  std::size_t views = 0;
  double psnr_db = 0.0;
  double ssim = 0.0;
  double depth_l1_m = 0.0;
  double coverage = 0.0;
};

/// The evaluation of a map over a sequence.
struct ViewEvaluation {
  ViewSummary all;        ///< every scored view
  ViewSummary keyframes;  ///< views of frames that became keyframes
  ViewSummary novel;      ///< views of frames that never did
  std::vector<ViewScore> views;
  /// The summary in a few lines (the runner prints it, view_evaluation.txt holds it).
  std::string report() const;
};

/// Scores one rendered view against the frame's input. `bgr` CV_8UC3, `depth_m` CV_32FC1 (0 or
/// non-finite: no depth), `dynamic_mask` CV_8UC1 (255 = dynamic) or empty (all static); all of
/// the rendered view's size. Throws std::invalid_argument for a type or size mismatch.
ViewScore scoreView(const RenderedView& rendered, const cv::Mat& bgr, const cv::Mat& depth_m,
                    const cv::Mat& dynamic_mask, const ViewEvaluationOptions& options);

/// The means over all views, keyframe views and novel views.
ViewEvaluation summarizeViews(std::vector<ViewScore> views);

/// view_evaluation.txt: report() and one line per view, written atomically.
void writeViewEvaluation(const std::string& path, const ViewEvaluation& evaluation);

}  // namespace dypho::mapping
