#include "dypho/tools/trajectory_plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/common/atomic_file.h"
#include "trajectory_plot_layout.h"

namespace dypho::tools {
namespace plot {

PlotAxes choosePlotAxes(const std::vector<Eigen::Vector3d>& gt_xyz) {
  PlotAxes axes;
  Eigen::Vector3d lo = gt_xyz[0], hi = gt_xyz[0];
  for (const auto& p : gt_xyz) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = hi - lo;
  std::array<int, 3> order{0, 1, 2};
  std::sort(order.begin(), order.end(), [&](int a, int b) { return extent[a] > extent[b]; });
  axes.ax = std::min(order[0], order[1]);
  axes.ay = std::max(order[0], order[1]);
  axes.gt_lo_m = lo;
  axes.gt_hi_m = hi;
  return axes;
}

PlotView fitPlotView(const AteResult& ate, const PlotAxes& axes) {
  const int ax = axes.ax, ay = axes.ay;
  // Data bounds over both trajectories, equal scale on both axes.
  double x0 = axes.gt_lo_m[ax], x1 = axes.gt_hi_m[ax], y0 = axes.gt_lo_m[ay], y1 = axes.gt_hi_m[ay];
  for (const auto& p : ate.est_aligned_xyz) {
    x0 = std::min(x0, p[ax]);
    x1 = std::max(x1, p[ax]);
    y0 = std::min(y0, p[ay]);
    y1 = std::max(y1, p[ay]);
  }
  const double pad = 0.05 * std::max({x1 - x0, y1 - y0, 0.02});
  x0 -= pad;
  x1 += pad;
  y0 -= pad;
  y1 += pad;
  const double px_per_m = std::min(kPlotWidth / (x1 - x0), kPlotHeight / (y1 - y0));
  const double cxm = 0.5 * (x0 + x1), cym = 0.5 * (y0 + y1);
  PlotView view;
  view.ax = ax;
  view.ay = ay;
  view.x0 = cxm - 0.5 * kPlotWidth / px_per_m;
  view.x1 = cxm + 0.5 * kPlotWidth / px_per_m;
  view.y0 = cym - 0.5 * kPlotHeight / px_per_m;
  view.y1 = cym + 0.5 * kPlotHeight / px_per_m;
  view.px_per_m = px_per_m;
  view.step_m = niceStep(std::max(view.x1 - view.x0, view.y1 - view.y0), 8);
  return view;
}

double niceStep(double span, int target) {
  const double raw = std::max(span, 1e-6) / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * p >= raw) return m * p;
  }
  return 10.0 * p;
}

}  // namespace plot

namespace {

using namespace plot;

const cv::Scalar kGtColour(0, 0, 0);
const cv::Scalar kEstColour(30, 30, 220);
const cv::Scalar kErrColour(200, 200, 200);
const cv::Scalar kGridColour(235, 235, 235);
constexpr int kShift = 4;  // sub-pixel drawing: coordinates * 16
const char* const kAxisNames = "xyz";

/// A tick value with as many decimals as `step` needs.
std::string tickLabel(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

/// `s` at `at` (baseline left) [px] in the plot's font.
void text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5,
          const cv::Scalar& colour = cv::Scalar(0, 0, 0), int thickness = 1) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

/// A pixel position in OpenCV's fixed point (kShift fractional bits), for sub-pixel drawing.
cv::Point toFixedPoint(const cv::Point2d& p) {
  return cv::Point(cvRound(p.x * (1 << kShift)), cvRound(p.y * (1 << kShift)));
}

/// The plot area of the image [px].
cv::Rect plotFrame() { return cv::Rect(kMarginLeft, kMarginTop, kPlotWidth, kPlotHeight); }

/// Grid and ticks in metres, the frame and the axis names.
void drawGrid(cv::Mat& img, const PlotView& view) {
  const cv::Rect frame = plotFrame();
  const double step = view.step_m;
  for (double v = std::ceil(view.x0 / step) * step; v <= view.x1; v += step) {
    const int u = cvRound(kMarginLeft + (v - view.x0) * view.px_per_m);
    cv::line(img, {u, frame.y}, {u, frame.y + frame.height}, kGridColour, 1);
    cv::line(img, {u, frame.y + frame.height}, {u, frame.y + frame.height + 6}, kGtColour, 1);
    text(img, tickLabel(v, step), {u - 18, frame.y + frame.height + 24}, 0.45);
  }
  for (double v = std::ceil(view.y0 / step) * step; v <= view.y1; v += step) {
    const int w = cvRound(kMarginTop + kPlotHeight - (v - view.y0) * view.px_per_m);
    cv::line(img, {frame.x, w}, {frame.x + frame.width, w}, kGridColour, 1);
    cv::line(img, {frame.x - 6, w}, {frame.x, w}, kGtColour, 1);
    text(img, tickLabel(v, step), {8, w + 5}, 0.45);
  }
  cv::rectangle(img, frame, kGtColour, 1);
  text(img, std::string(1, kAxisNames[view.ax]) + " [m]", {frame.x + frame.width / 2 - 20, frame.y + frame.height + 48},
       0.55);
  text(img, std::string(1, kAxisNames[view.ay]) + " [m]", {8, frame.y - 12}, 0.55);
}

/// Error segments, then the aligned estimate, then the ground truth and a circle at its start.
void drawTrajectories(cv::Mat& img, const AteResult& ate, const PlotView& view) {
  // Error segments, then the trajectories.
  // Every point lies inside `frame` (the bounds include both trajectories), so draw on `img`.
  for (std::size_t i = 0; i < ate.gt_xyz.size(); ++i) {
    cv::line(img, toFixedPoint(view.toPx(ate.gt_xyz[i])), toFixedPoint(view.toPx(ate.est_aligned_xyz[i])), kErrColour,
             1, cv::LINE_AA, kShift);
  }
  // Estimate first, ground truth (the reference) on top.
  for (std::size_t i = 1; i < ate.gt_xyz.size(); ++i) {
    cv::line(img, toFixedPoint(view.toPx(ate.est_aligned_xyz[i - 1])), toFixedPoint(view.toPx(ate.est_aligned_xyz[i])),
             kEstColour, 2, cv::LINE_AA, kShift);
  }
  for (std::size_t i = 1; i < ate.gt_xyz.size(); ++i) {
    cv::line(img, toFixedPoint(view.toPx(ate.gt_xyz[i - 1])), toFixedPoint(view.toPx(ate.gt_xyz[i])), kGtColour, 2,
             cv::LINE_AA, kShift);
  }
  cv::circle(img, toFixedPoint(view.toPx(ate.gt_xyz.front())), 5 << kShift, kGtColour, 2, cv::LINE_AA, kShift);
}

/// Title, legend, the view's axes and grid step, and the ATE numbers.
void drawLegend(cv::Mat& img, const AteResult& ate, const std::string& title, const PlotView& view) {
  const cv::Rect frame = plotFrame();
  text(img, title, {kMarginLeft, 35}, 0.75, kGtColour, 2);
  const int ly = frame.y + frame.height + 80;
  cv::line(img, {kMarginLeft, ly - 5}, {kMarginLeft + 40, ly - 5}, kGtColour, 2);
  text(img, "ground truth (circle = start)", {kMarginLeft + 50, ly});
  cv::line(img, {kMarginLeft + 330, ly - 5}, {kMarginLeft + 370, ly - 5}, kEstColour, 2);
  text(img, "estimate (rigidly aligned, no scale)", {kMarginLeft + 380, ly});
  cv::line(img, {kMarginLeft + 700, ly - 5}, {kMarginLeft + 740, ly - 5}, kErrColour, 2);
  text(img, "error", {kMarginLeft + 750, ly});
  char buf[256];
  std::snprintf(buf, sizeof(buf), "view: %c (right) vs %c (up), the two axes of largest extent; grid %s m",
                kAxisNames[view.ax], kAxisNames[view.ay], tickLabel(view.step_m, view.step_m).c_str());
  text(img, buf, {kMarginLeft, ly + 28}, 0.5);
  std::snprintf(buf, sizeof(buf), "ATE rmse %.2f cm, mean %.2f cm, median %.2f cm, max %.2f cm, %zu poses",
                ate.rmse_m * 100.0, ate.mean_m * 100.0, ate.median_m * 100.0, ate.max_m * 100.0, ate.num_pairs);
  text(img, buf, {kMarginLeft, ly + 52}, 0.5);
}

}  // namespace

cv::Mat renderTrajectoryPlot(const AteResult& ate, const std::string& title) {
  if (ate.gt_xyz.empty() || ate.gt_xyz.size() != ate.est_aligned_xyz.size()) {
    throw std::runtime_error("trajectory plot: the ATE result has no (or mismatched) positions");
  }
  // Axes: the two with the largest ground-truth extent, kept in x, y, z order.
  const PlotView view = fitPlotView(ate, choosePlotAxes(ate.gt_xyz));
  cv::Mat img(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  drawGrid(img, view);
  drawTrajectories(img, ate, view);
  drawLegend(img, ate, title, view);
  return img;
}

void writeTrajectoryPlotPng(const std::string& path, const AteResult& ate, const std::string& title) {
  const cv::Mat img = renderTrajectoryPlot(ate, title);
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", img, png)) {
    throw std::runtime_error("trajectory plot: PNG encoding failed for '" + path + "'");
  }
  writeFileAtomically(
      path,
      [&png](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
      },
      /*binary=*/true);
}

}  // namespace dypho::tools
