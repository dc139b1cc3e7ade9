#pragma once
/// \file trajectory_plot.h
/// PNG plot of an ATE result (ground truth vs aligned estimate), drawn with OpenCV only.

#include <string>

#include <opencv2/core.hpp>

#include "dypho/tools/evaluation.h"

namespace dypho::tools {

/// Renders the plot (BGR CV_8UC3, 1000x800 px): the two axes with the largest extent of the
/// ground truth (named in the legend, e.g. "view: x (right) vs y (up)"), equal scale, metre
/// ticks, ground truth (black), aligned estimate (red), grey error segments, legend, title and
/// the ATE numbers. Throws std::runtime_error when `ate` has no positions.
cv::Mat renderTrajectoryPlot(const AteResult& ate, const std::string& title);

/// renderTrajectoryPlot() encoded as PNG and written atomically to `path` (temporary file +
/// rename). Throws std::runtime_error when encoding or writing fails.
void writeTrajectoryPlotPng(const std::string& path, const AteResult& ate, const std::string& title);

}  // namespace dypho::tools
