#pragma once
/// \file keypoint_grid.h
/// Keypoints bucketed by undistorted position for window queries (internal to
/// dypho_tracking_core: the projection search of FeatureMatcher and the fuse step).

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

namespace dypho {
namespace tracking {

/// Buckets frame keypoints by undistorted position for window queries.
class KeypointGrid {
 public:
  KeypointGrid(const std::vector<Eigen::Vector2d>& uv, double cell_px) : cell_(cell_px) {
    if (uv.empty()) return;
    min_ = max_ = uv.front();
    for (const auto& p : uv) {
      min_ = min_.cwiseMin(p);
      max_ = max_.cwiseMax(p);
    }
    cols_ = static_cast<int>((max_.x() - min_.x()) / cell_) + 1;
    rows_ = static_cast<int>((max_.y() - min_.y()) / cell_) + 1;
    cells_.resize(static_cast<size_t>(cols_ * rows_));
    for (size_t i = 0; i < uv.size(); ++i) {
      cells_[static_cast<size_t>(cellIndex(uv[i]))].push_back(static_cast<int>(i));
    }
  }

  /// Calls f(index) for every keypoint whose cell overlaps the square [c - r, c + r].
  template <typename F>
  void forEachNear(const Eigen::Vector2d& c, double r, F&& f) const {
    if (cells_.empty()) return;
    const int c0 = std::max(0, static_cast<int>(std::floor((c.x() - r - min_.x()) / cell_)));
    const int c1 = std::min(cols_ - 1, static_cast<int>(std::floor((c.x() + r - min_.x()) / cell_)));
    const int r0 = std::max(0, static_cast<int>(std::floor((c.y() - r - min_.y()) / cell_)));
    const int r1 = std::min(rows_ - 1, static_cast<int>(std::floor((c.y() + r - min_.y()) / cell_)));
    for (int row = r0; row <= r1; ++row) {
      for (int col = c0; col <= c1; ++col) {
        for (int i : cells_[static_cast<size_t>(row * cols_ + col)]) f(i);
      }
    }
  }

 private:
  int cellIndex(const Eigen::Vector2d& p) const {
    const int col = std::min(cols_ - 1, static_cast<int>((p.x() - min_.x()) / cell_));
    const int row = std::min(rows_ - 1, static_cast<int>((p.y() - min_.y()) / cell_));
    return row * cols_ + col;
  }
  double cell_;
  Eigen::Vector2d min_ = Eigen::Vector2d::Zero(), max_ = Eigen::Vector2d::Zero();
  int cols_ = 0, rows_ = 0;
  std::vector<std::vector<int>> cells_;
};

}  // namespace tracking
}  // namespace dypho
