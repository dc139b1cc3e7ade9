#pragma once
/// \file trajectory_plot_layout.h
/// Internal to trajectory_plot.cpp (and its test): where the plot puts the trajectories, in
/// pixels of the 1000x800 px image.

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "dypho/tools/evaluation.h"

namespace dypho::tools::plot {

constexpr int kWidth = 1000;
constexpr int kHeight = 800;
constexpr int kMarginLeft = 90;
constexpr int kMarginRight = 30;
constexpr int kMarginTop = 60;
constexpr int kMarginBottom = 150;                                 // room for tick labels, legend and ATE text
constexpr int kPlotWidth = kWidth - kMarginLeft - kMarginRight;    ///< plot area [px]
constexpr int kPlotHeight = kHeight - kMarginTop - kMarginBottom;  ///< plot area [px]

/// The two plotted axes (0 = x, 1 = y, 2 = z) and the ground-truth bounds they came from.
struct PlotAxes {
  int ax = 0;                                         ///< drawn to the right
  int ay = 1;                                         ///< drawn up
  Eigen::Vector3d gt_lo_m = Eigen::Vector3d::Zero();  ///< per-axis minimum of the ground truth [m]
  Eigen::Vector3d gt_hi_m = Eigen::Vector3d::Zero();  ///< per-axis maximum of the ground truth [m]
};

/// The two axes with the largest ground-truth extent, kept in x, y, z order. `gt_xyz` not empty.
PlotAxes choosePlotAxes(const std::vector<Eigen::Vector3d>& gt_xyz);

/// The metres shown on the plot area: both trajectories with a 5 % pad, equal scale on both axes.
struct PlotView {
  int ax = 0;
  int ay = 1;
  double x0 = 0.0, x1 = 1.0;  ///< visible range along `ax` [m]
  double y0 = 0.0, y1 = 1.0;  ///< visible range along `ay` [m]
  double px_per_m = 1.0;      ///< the one scale of both axes [px/m]
  double step_m = 1.0;        ///< grid and tick spacing [m] (1, 2 or 5 times a power of ten)

  /// A position [m] as a pixel of the image (y down).
  cv::Point2d toPx(const Eigen::Vector3d& p) const {
    return cv::Point2d(kMarginLeft + (p[ax] - x0) * px_per_m, kMarginTop + kPlotHeight - (p[ay] - y0) * px_per_m);
  }
};

/// Fits the view to the ground truth (bounds in `axes`) and the aligned estimate of `ate`.
PlotView fitPlotView(const AteResult& ate, const PlotAxes& axes);

/// 1, 2 or 5 times a power of ten, giving about `target` intervals over `span`.
double niceStep(double span, int target);

}  // namespace dypho::tools::plot
