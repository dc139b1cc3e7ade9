// The trajectory plot's layout steps (trajectory_plot_layout.h): axis choice and the view fit.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "trajectory_plot_layout.h"

using namespace dypho::tools;
using namespace dypho::tools::plot;

namespace DYPHO_UNITY_ID {

/// A path that spans 4 m in x, 0.5 m in y and 2 m in z.
std::vector<Eigen::Vector3d> xzPath() {
  std::vector<Eigen::Vector3d> xyz;
  for (int i = 0; i <= 20; ++i) {
    const double t = i / 20.0;
    xyz.emplace_back(-1.0 + 4.0 * t, 0.5 * t * t, 2.0 * std::sin(std::acos(-1.0) * t));
  }
  return xyz;
}

TEST(TrajectoryPlotLayout, ChoosesTheTwoLargestExtentsInXyzOrder) {
  const std::vector<Eigen::Vector3d> gt = xzPath();
  const PlotAxes axes = choosePlotAxes(gt);
  EXPECT_EQ(axes.ax, 0);  // x: 4 m
  EXPECT_EQ(axes.ay, 2);  // z: 2 m (y spans 0.5 m)
  EXPECT_DOUBLE_EQ(axes.gt_lo_m.x(), -1.0);
  EXPECT_DOUBLE_EQ(axes.gt_hi_m.x(), 3.0);
  EXPECT_DOUBLE_EQ(axes.gt_hi_m.y(), 0.5);

  // z larger than x: still drawn x right, z up (x, y, z order).
  std::vector<Eigen::Vector3d> tall;
  for (const auto& p : gt) tall.emplace_back(p.x(), p.y(), 3.0 * p.z());
  const PlotAxes tall_axes = choosePlotAxes(tall);
  EXPECT_EQ(tall_axes.ax, 0);
  EXPECT_EQ(tall_axes.ay, 2);
}

TEST(TrajectoryPlotLayout, ViewHoldsBothTrajectoriesAtOneScale) {
  AteResult ate;
  ate.gt_xyz = xzPath();
  for (const auto& p : ate.gt_xyz) ate.est_aligned_xyz.push_back(p + Eigen::Vector3d(0.3, 0.0, -0.4));
  const PlotView view = fitPlotView(ate, choosePlotAxes(ate.gt_xyz));
  ASSERT_GT(view.px_per_m, 0.0);
  // One scale: the visible ranges fill the plot area exactly on both axes.
  EXPECT_NEAR((view.x1 - view.x0) * view.px_per_m, kPlotWidth, 1e-9);
  EXPECT_NEAR((view.y1 - view.y0) * view.px_per_m, kPlotHeight, 1e-9);
  for (const auto* path : {&ate.gt_xyz, &ate.est_aligned_xyz}) {
    for (const auto& p : *path) {
      const cv::Point2d px = view.toPx(p);
      EXPECT_GT(px.x, kMarginLeft);
      EXPECT_LT(px.x, kMarginLeft + kPlotWidth);
      EXPECT_GT(px.y, kMarginTop);
      EXPECT_LT(px.y, kMarginTop + kPlotHeight);
    }
  }
  // The grid step is 1, 2 or 5 times a power of ten.
  const double mantissa = view.step_m / std::pow(10.0, std::floor(std::log10(view.step_m)));
  EXPECT_TRUE(std::abs(mantissa - 1.0) < 1e-9 || std::abs(mantissa - 2.0) < 1e-9 || std::abs(mantissa - 5.0) < 1e-9)
      << view.step_m;
  EXPECT_DOUBLE_EQ(niceStep(8.0, 8), 1.0);
  EXPECT_DOUBLE_EQ(niceStep(12.0, 8), 2.0);
  EXPECT_NEAR(niceStep(0.3, 8), 0.05, 1e-15);
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
