#pragma once
/// \file orb_grid.h
/// OrbExtractor's grid over a pyramid level and its round-robin choice of keypoints over the
/// grid's cells (internal to dypho_tracking_core; tested alone in test_orb_extractor.cpp).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace dypho {
namespace tracking {

/// The usable area of one pyramid level (inside the edge border) and its grid of cells.
struct LevelGrid {
  int x_lo = 0, y_lo = 0, x_hi = 0, y_hi = 0;  ///< usable area [level px], hi exclusive
  int ncols = 1, nrows = 1;                    ///< cells across and down
  double cell_w = 0, cell_h = 0;               ///< cell size [level px]

  /// Cell `i` (row-major), clipped to the usable area [level px].
  cv::Rect cellRect(std::size_t i) const {
    const cv::Rect usable(x_lo, y_lo, x_hi - x_lo, y_hi - y_lo);
    const int c = static_cast<int>(i) % ncols, r = static_cast<int>(i) / ncols;
    const cv::Rect cell_rect(x_lo + static_cast<int>(c * cell_w), y_lo + static_cast<int>(r * cell_h),
                             static_cast<int>(std::ceil(cell_w)), static_cast<int>(std::ceil(cell_h)));
    return cell_rect & usable;
  }
};

/// The grid of a level of `level_size` inside a border of `edge_px`, cells of about `cell_px`
/// (at least one across and down); nullopt when the level is too small for a patch.
inline std::optional<LevelGrid> levelGrid(const cv::Size& level_size, int edge_px, int cell_px) {
  LevelGrid g;
  g.x_lo = edge_px;
  g.y_lo = edge_px;
  g.x_hi = level_size.width - edge_px;
  g.y_hi = level_size.height - edge_px;
  if (g.x_hi - g.x_lo < 8 || g.y_hi - g.y_lo < 8) return std::nullopt;  // level too small for a patch
  const int cell = cell_px;
  g.ncols = std::max(1, (g.x_hi - g.x_lo + cell / 2) / cell);
  g.nrows = std::max(1, (g.y_hi - g.y_lo + cell / 2) / cell);
  g.cell_w = static_cast<double>(g.x_hi - g.x_lo) / g.ncols;
  g.cell_h = static_cast<double>(g.y_hi - g.y_lo) / g.nrows;
  return g;
}

/// Distance of every pixel to the nearest dynamic pixel (`mask` != 0) as cv::distanceTransform
/// (DIST_L2, 3x3 chamfer) gives it on the whole image, for the distances below `reach_px`; a pixel
/// farther than that may get any value >= reach_px (float max). The transform runs only on the
/// dynamic pixels' bounding box grown by the reach: a 3x3 chamfer path from a dynamic pixel never
/// leaves the box of its two ends, and every axial step costs at least 0.955 px. `mask` CV_8UC1
/// with at least one dynamic pixel; returns CV_32FC1 [px].
inline cv::Mat distanceToDynamic(const cv::Mat& mask, double reach_px) {
  constexpr double kSmallestChamferStep = 0.955;  // OpenCV's axial step of DIST_L2 with a 3x3 mask
  const int margin = static_cast<int>(std::ceil(reach_px / kSmallestChamferStep)) + 1;
  cv::Rect box = cv::boundingRect(mask);
  box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
        cv::Rect(0, 0, mask.cols, mask.rows);
  cv::Mat distance(mask.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::max()));
  cv::Mat is_static;
  cv::compare(mask(box), 0, is_static, cv::CMP_EQ);
  cv::Mat distance_in_box = distance(box);
  cv::distanceTransform(is_static, distance_in_box, cv::DIST_L2, 3);
  return distance;
}

/// Keeps up to `budget` keypoints, taking cells round-robin (best response first in each round).
/// Sorts each cell by response, best first.
inline std::vector<cv::KeyPoint> distributeOverCells(std::vector<std::vector<cv::KeyPoint>>& cells, int budget) {
  std::vector<cv::KeyPoint> out;
  const auto by_response = [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; };
  size_t max_len = 0;
  for (auto& cell : cells) {
    std::sort(cell.begin(), cell.end(), by_response);
    max_len = std::max(max_len, cell.size());
  }
  for (size_t rank = 0; rank < max_len && static_cast<int>(out.size()) < budget; ++rank) {
    std::vector<cv::KeyPoint> round;
    for (const auto& cell : cells) {
      if (rank < cell.size()) round.push_back(cell[rank]);
    }
    const size_t room = static_cast<size_t>(budget) - out.size();
    if (round.size() > room) {
      std::partial_sort(round.begin(), round.begin() + static_cast<long>(room), round.end(), by_response);
      round.resize(room);
    }
    out.insert(out.end(), round.begin(), round.end());
  }
  return out;
}

}  // namespace tracking
}  // namespace dypho
