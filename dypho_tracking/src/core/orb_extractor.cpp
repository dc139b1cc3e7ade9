#include "dypho/tracking/orb_extractor.h"

#include "dypho/tracking/relaxed_feature_test.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace dypho {
namespace tracking {
namespace {

constexpr int kHalfPatch = 15;  // radius of the orientation disc (ORB patch 31 x 31)
constexpr int kFastBorder = 3;  // FAST needs 3 px around a candidate

/// Orientation by intensity centroid over a disc of radius kHalfPatch [deg, 0..360).
float intensityCentroidAngle(const cv::Mat& image, int x, int y, const std::vector<int>& umax) {
  long m01 = 0;
  long m10 = 0;
  const uchar* center = image.ptr<uchar>(y) + x;
  for (int u = -kHalfPatch; u <= kHalfPatch; ++u) m10 += u * center[u];
  const int step = static_cast<int>(image.step1());
  for (int v = 1; v <= kHalfPatch; ++v) {
    long v_sum = 0;
    const int d = umax[static_cast<size_t>(v)];
    for (int u = -d; u <= d; ++u) {
      const int val_plus = center[u + v * step];
      const int val_minus = center[u - v * step];
      v_sum += (val_plus - val_minus);
      m10 += u * (val_plus + val_minus);
    }
    m01 += v * v_sum;
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
}

/// Keeps up to `budget` keypoints, taking cells round-robin (best response first in each round).
std::vector<cv::KeyPoint> distributeOverCells(std::vector<std::vector<cv::KeyPoint>>& cells,
                                              int budget) {
  std::vector<cv::KeyPoint> out;
  const auto by_response = [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    return a.response > b.response;
  };
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
      std::partial_sort(round.begin(), round.begin() + static_cast<long>(room), round.end(),
                        by_response);
      round.resize(room);
    }
    out.insert(out.end(), round.begin(), round.end());
  }
  return out;
}

}  // namespace

OrbExtractor::OrbExtractor(const TrackingOptions& options) : options_(options) {
  options_.validate();
  const int levels = options_.num_levels;
  level_scales_.resize(static_cast<size_t>(levels));
  for (int l = 0; l < levels; ++l) {
    // Same float arithmetic as cv::ORB so that both pyramids have identical level sizes.
    level_scales_[static_cast<size_t>(l)] =
        static_cast<float>(std::pow(options_.scale_factor, static_cast<double>(l)));
  }
  // Geometric budget per level: n_l = n_0 f^l with f = 1 / scale_factor, sum = num_features.
  const double f = 1.0 / options_.scale_factor;
  double n_l = options_.num_features * (1.0 - f) / (1.0 - std::pow(f, levels));
  int assigned = 0;
  features_per_level_.resize(static_cast<size_t>(levels));
  for (int l = 0; l < levels - 1; ++l) {
    features_per_level_[static_cast<size_t>(l)] = static_cast<int>(std::lround(n_l));
    assigned += features_per_level_[static_cast<size_t>(l)];
    n_l *= f;
  }
  features_per_level_.back() = std::max(0, options_.num_features - assigned);

  umax_.assign(kHalfPatch + 1, 0);
  for (int v = 0; v <= kHalfPatch; ++v) {
    umax_[static_cast<size_t>(v)] =
        static_cast<int>(std::floor(std::sqrt(double(kHalfPatch * kHalfPatch - v * v))));
  }
  orb_ = cv::ORB::create(options_.num_features, static_cast<float>(options_.scale_factor),
                         options_.num_levels, kEdgePx, 0, 2, cv::ORB::FAST_SCORE, 31,
                         options_.fast_threshold);
}

template <typename Allowed>
std::vector<cv::KeyPoint> OrbExtractor::relaxedCandidates(const cv::Mat& level_image,
                                                          const cv::Rect& cell, double sigma_dy,
                                                          const Allowed& is_allowed) const {
  // Candidates on a 2-px lattice (the ring has radius 3, so neighbours on the lattice share most
  // of their ring), best score first, then a 3-px non-maximum suppression inside the cell.
  std::vector<cv::KeyPoint> found;
  for (int y = cell.y; y < cell.y + cell.height; y += 2) {
    for (int x = cell.x; x < cell.x + cell.width; x += 2) {
      const RelaxedResponse r = relaxedResponse(level_image, x, y, sigma_dy);
      if (!isRelaxedFeature(r, options_.relaxed_min_count, options_.fast_threshold)) continue;
      if (!is_allowed(static_cast<float>(x), static_cast<float>(y))) continue;
      // Scores below every FAST corner's: relaxed features rank after FAST corners.
      found.emplace_back(static_cast<float>(x), static_cast<float>(y), 7.f, -1.f,
                         r.score / 16.f * 1e-3f);
    }
  }
  std::sort(found.begin(), found.end(),
            [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  std::vector<cv::KeyPoint> kept;
  for (const cv::KeyPoint& kp : found) {
    const bool near = std::any_of(kept.begin(), kept.end(), [&](const cv::KeyPoint& k) {
      return std::abs(k.pt.x - kp.pt.x) <= 3.f && std::abs(k.pt.y - kp.pt.y) <= 3.f;
    });
    if (!near) kept.push_back(kp);
  }
  return kept;
}

OrbFeatures OrbExtractor::extract(const cv::Mat& gray, const cv::Mat& mask) {
  if (gray.empty() || gray.type() != CV_8UC1 || gray.cols < 64 || gray.rows < 64) {
    throw std::invalid_argument(
        "OrbExtractor::extract: need a CV_8UC1 image of at least 64x64 px (convert colour with "
        "cv::cvtColor(..., COLOR_BGR2GRAY))");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != gray.size())) {
    throw std::invalid_argument(
        "OrbExtractor::extract: the mask must be empty or CV_8UC1 with the image size "
        "(255 = dynamic, 0 = static)");
  }
  OrbFeatures out;

  // Distance of every pixel to the nearest dynamic pixel [level-0 px]; empty = no dynamic pixel.
  cv::Mat dist_to_dynamic;
  if (!mask.empty()) {
    const int dynamic = cv::countNonZero(mask);
    out.masked_fraction = static_cast<double>(dynamic) / static_cast<double>(mask.total());
    if (dynamic == static_cast<int>(mask.total())) return out;  // nothing static to describe
    if (dynamic > 0) {
      cv::Mat is_static;
      cv::compare(mask, 0, is_static, cv::CMP_EQ);
      cv::distanceTransform(is_static, dist_to_dynamic, cv::DIST_L2, 3);
    }
  }
  const int threshold = std::max(
      options_.min_fast_threshold,
      static_cast<int>(std::lround(options_.fast_threshold *
                                   (1.0 - options_.mask_threshold_relaxation * out.masked_fraction))));
  out.fast_threshold_used = threshold;
  const double sigma_dy =
      relaxedThreshold(options_.relaxed_sigma0, options_.relaxed_k, out.masked_fraction);
  out.relaxed_threshold_used = sigma_dy;
  // The relaxed tier is specific to dynamic masking (paper): it runs when part of the view is masked.
  const bool use_relaxed = options_.relaxed_features && out.masked_fraction > 0;

  std::vector<cv::KeyPoint> all;
  cv::Mat level_image = gray;
  for (int level = 0; level < options_.num_levels; ++level) {
    const double scale = level_scales_[static_cast<size_t>(level)];
    if (level > 0) {
      const cv::Size size(cvRound(gray.cols / scale), cvRound(gray.rows / scale));
      cv::Mat next;
      cv::resize(level_image, next, size, 0, 0, cv::INTER_LINEAR);
      level_image = next;
    }
    const int x_lo = kEdgePx, y_lo = kEdgePx;
    const int x_hi = level_image.cols - kEdgePx, y_hi = level_image.rows - kEdgePx;
    if (x_hi - x_lo < 8 || y_hi - y_lo < 8) break;  // level too small for a patch

    const double min_mask_distance = std::max(1.0, options_.mask_border_px * scale);
    const auto is_allowed = [&](float x, float y) {
      if (dist_to_dynamic.empty()) return true;
      const int u = std::min(gray.cols - 1, static_cast<int>(std::lround(x * scale)));
      const int v = std::min(gray.rows - 1, static_cast<int>(std::lround(y * scale)));
      return dist_to_dynamic.at<float>(v, u) >= min_mask_distance;
    };

    // One FAST pass per level at the low threshold; cells then take the corners scoring
    // >= `threshold` and fall back to the weaker ones (>= min_fast_threshold) only when they have
    // none (FAST's response is the largest threshold at which the pixel is still a corner).
    const cv::Rect region(x_lo - kFastBorder, y_lo - kFastBorder, x_hi - x_lo + 2 * kFastBorder,
                          y_hi - y_lo + 2 * kFastBorder);
    std::vector<cv::KeyPoint> found;
    cv::FAST(level_image(region), found, options_.min_fast_threshold, true);
    const int cell = options_.grid_cell_px;
    const int ncols = std::max(1, (x_hi - x_lo + cell / 2) / cell);
    const int nrows = std::max(1, (y_hi - y_lo + cell / 2) / cell);
    const double cell_w = static_cast<double>(x_hi - x_lo) / ncols;
    const double cell_h = static_cast<double>(y_hi - y_lo) / nrows;
    std::vector<std::vector<cv::KeyPoint>> strong(static_cast<size_t>(ncols * nrows));
    std::vector<std::vector<cv::KeyPoint>> weak(strong.size());
    for (cv::KeyPoint kp : found) {
      kp.pt.x += static_cast<float>(region.x);
      kp.pt.y += static_cast<float>(region.y);
      if (kp.pt.x < x_lo || kp.pt.x >= x_hi || kp.pt.y < y_lo || kp.pt.y >= y_hi) continue;
      if (!is_allowed(kp.pt.x, kp.pt.y)) continue;
      const int c = std::min(ncols - 1, static_cast<int>((kp.pt.x - x_lo) / cell_w));
      const int r = std::min(nrows - 1, static_cast<int>((kp.pt.y - y_lo) / cell_h));
      const size_t index = static_cast<size_t>(r * ncols + c);
      (kp.response >= threshold ? strong : weak)[index].push_back(kp);
    }
    std::vector<std::vector<cv::KeyPoint>> cells;
    cells.reserve(strong.size());
    std::vector<size_t> empty_cells;
    for (size_t i = 0; i < strong.size(); ++i) {
      if (!strong[i].empty()) {
        cells.push_back(std::move(strong[i]));
      } else if (!weak[i].empty()) {
        cells.push_back(std::move(weak[i]));
      } else {
        empty_cells.push_back(i);
      }
    }
    const int budget = features_per_level_[static_cast<size_t>(level)];
    std::vector<cv::KeyPoint> chosen = distributeOverCells(cells, budget);
    // Relaxed features only make up a deficit left by FAST, and only in cells without a corner.
    if (use_relaxed && static_cast<int>(chosen.size()) < budget) {
      std::vector<std::vector<cv::KeyPoint>> relaxed_cells;
      const cv::Rect usable(x_lo, y_lo, x_hi - x_lo, y_hi - y_lo);
      for (size_t i : empty_cells) {
        const int c = static_cast<int>(i) % ncols, r = static_cast<int>(i) / ncols;
        const cv::Rect cell_rect(x_lo + static_cast<int>(c * cell_w),
                                 y_lo + static_cast<int>(r * cell_h),
                                 static_cast<int>(std::ceil(cell_w)), static_cast<int>(std::ceil(cell_h)));
        std::vector<cv::KeyPoint> relaxed =
            relaxedCandidates(level_image, cell_rect & usable, sigma_dy, is_allowed);
        if (!relaxed.empty()) relaxed_cells.push_back(std::move(relaxed));
      }
      const std::vector<cv::KeyPoint> extra =
          distributeOverCells(relaxed_cells, budget - static_cast<int>(chosen.size()));
      out.num_relaxed += static_cast<int>(extra.size());
      chosen.insert(chosen.end(), extra.begin(), extra.end());
    }
    for (cv::KeyPoint& kp : chosen) {
      kp.angle = intensityCentroidAngle(level_image, cvRound(kp.pt.x), cvRound(kp.pt.y), umax_);
      kp.octave = level;
      kp.size = static_cast<float>(31.0 * scale);
      kp.pt.x = static_cast<float>(kp.pt.x * scale);
      kp.pt.y = static_cast<float>(kp.pt.y * scale);
      kp.class_id = static_cast<int>(all.size());
      all.push_back(kp);
    }
  }
  if (all.empty()) return out;
  // cv::ORB computes rBRIEF on its own copy of the pyramid (Gaussian-blurred), using our angles.
  orb_->compute(gray, all, out.descriptors);
  out.keypoints = std::move(all);
  if (static_cast<int>(out.keypoints.size()) != out.descriptors.rows) {
    throw std::logic_error("OrbExtractor: cv::ORB::compute returned " +
                           std::to_string(out.descriptors.rows) + " descriptors for " +
                           std::to_string(out.keypoints.size()) + " keypoints");
  }
  return out;
}

}  // namespace tracking
}  // namespace dypho
