#include "dypho/tools/trajectory_plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/common/atomic_file.h"

namespace dypho::tools {
namespace {

constexpr int kWidth = 1000;
constexpr int kHeight = 800;
constexpr int kMarginLeft = 90;
constexpr int kMarginRight = 30;
constexpr int kMarginTop = 60;
constexpr int kMarginBottom = 150;  // room for tick labels, legend and ATE text
const cv::Scalar kGtColour(0, 0, 0);
const cv::Scalar kEstColour(30, 30, 220);
const cv::Scalar kErrColour(200, 200, 200);
const cv::Scalar kGridColour(235, 235, 235);

/// 1, 2 or 5 times a power of ten, giving about `target` intervals over `span`.
double niceStep(double span, int target) {
  const double raw = std::max(span, 1e-6) / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * p >= raw) return m * p;
  }
  return 10.0 * p;
}

std::string tickLabel(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5,
          const cv::Scalar& colour = cv::Scalar(0, 0, 0), int thickness = 1) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

}  // namespace

cv::Mat renderTrajectoryPlot(const AteResult& ate, const std::string& title) {
  if (ate.gt_xyz.empty() || ate.gt_xyz.size() != ate.est_aligned_xyz.size()) {
    throw std::runtime_error("trajectory plot: the ATE result has no (or mismatched) positions");
  }
  // Axes: the two with the largest ground-truth extent, kept in x, y, z order.
  Eigen::Vector3d lo = ate.gt_xyz[0], hi = ate.gt_xyz[0];
  for (const auto& p : ate.gt_xyz) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = hi - lo;
  std::array<int, 3> axes{0, 1, 2};
  std::sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });
  const int ax = std::min(axes[0], axes[1]);
  const int ay = std::max(axes[0], axes[1]);
  const char* names = "xyz";

  // Data bounds over both trajectories, equal scale on both axes.
  double x0 = lo[ax], x1 = hi[ax], y0 = lo[ay], y1 = hi[ay];
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
  const int plot_w = kWidth - kMarginLeft - kMarginRight;
  const int plot_h = kHeight - kMarginTop - kMarginBottom;
  const double px_per_m = std::min(plot_w / (x1 - x0), plot_h / (y1 - y0));
  const double cxm = 0.5 * (x0 + x1), cym = 0.5 * (y0 + y1);
  x0 = cxm - 0.5 * plot_w / px_per_m;
  x1 = cxm + 0.5 * plot_w / px_per_m;
  y0 = cym - 0.5 * plot_h / px_per_m;
  y1 = cym + 0.5 * plot_h / px_per_m;
  auto toPx = [&](const Eigen::Vector3d& p) {
    return cv::Point2d(kMarginLeft + (p[ax] - x0) * px_per_m,
                       kMarginTop + plot_h - (p[ay] - y0) * px_per_m);
  };
  constexpr int kShift = 4;  // sub-pixel drawing: coordinates * 16
  auto fx = [&](const cv::Point2d& p) {
    return cv::Point(cvRound(p.x * (1 << kShift)), cvRound(p.y * (1 << kShift)));
  };

  cv::Mat img(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Rect frame(kMarginLeft, kMarginTop, plot_w, plot_h);

  // Grid and ticks in metres.
  const double step = niceStep(std::max(x1 - x0, y1 - y0), 8);
  for (double v = std::ceil(x0 / step) * step; v <= x1; v += step) {
    const int u = cvRound(kMarginLeft + (v - x0) * px_per_m);
    cv::line(img, {u, frame.y}, {u, frame.y + frame.height}, kGridColour, 1);
    cv::line(img, {u, frame.y + frame.height}, {u, frame.y + frame.height + 6}, kGtColour, 1);
    text(img, tickLabel(v, step), {u - 18, frame.y + frame.height + 24}, 0.45);
  }
  for (double v = std::ceil(y0 / step) * step; v <= y1; v += step) {
    const int w = cvRound(kMarginTop + plot_h - (v - y0) * px_per_m);
    cv::line(img, {frame.x, w}, {frame.x + frame.width, w}, kGridColour, 1);
    cv::line(img, {frame.x - 6, w}, {frame.x, w}, kGtColour, 1);
    text(img, tickLabel(v, step), {8, w + 5}, 0.45);
  }
  cv::rectangle(img, frame, kGtColour, 1);
  text(img, std::string(1, names[ax]) + " [m]", {frame.x + frame.width / 2 - 20, frame.y + frame.height + 48}, 0.55);
  text(img, std::string(1, names[ay]) + " [m]", {8, frame.y - 12}, 0.55);

  // Error segments, then the trajectories.
  // Every point lies inside `frame` (the bounds include both trajectories), so draw on `img`.
  for (std::size_t i = 0; i < ate.gt_xyz.size(); ++i) {
    cv::line(img, fx(toPx(ate.gt_xyz[i])), fx(toPx(ate.est_aligned_xyz[i])),
             kErrColour, 1, cv::LINE_AA, kShift);
  }
  // Estimate first, ground truth (the reference) on top.
  for (std::size_t i = 1; i < ate.gt_xyz.size(); ++i) {
    cv::line(img, fx(toPx(ate.est_aligned_xyz[i - 1])), fx(toPx(ate.est_aligned_xyz[i])), kEstColour, 2,
             cv::LINE_AA, kShift);
  }
  for (std::size_t i = 1; i < ate.gt_xyz.size(); ++i) {
    cv::line(img, fx(toPx(ate.gt_xyz[i - 1])), fx(toPx(ate.gt_xyz[i])), kGtColour, 2, cv::LINE_AA, kShift);
  }
  cv::circle(img, fx(toPx(ate.gt_xyz.front())), 5 << kShift, kGtColour, 2, cv::LINE_AA, kShift);

  // Title, legend, numbers.
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
                names[ax], names[ay], tickLabel(step, step).c_str());
  text(img, buf, {kMarginLeft, ly + 28}, 0.5);
  std::snprintf(buf, sizeof(buf), "ATE rmse %.2f cm, mean %.2f cm, median %.2f cm, max %.2f cm, %zu poses",
                ate.rmse_m * 100.0, ate.mean_m * 100.0, ate.median_m * 100.0, ate.max_m * 100.0,
                ate.num_pairs);
  text(img, buf, {kMarginLeft, ly + 52}, 0.5);
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
