#include "dypho/tracking/orb_extractor.h"

#include "dypho/tracking/relaxed_feature_test.h"
#include "orb_grid.h"

#include <algorithm>
#include <cmath>
#include <optional>
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

/// Throws std::invalid_argument unless `gray` is CV_8UC1 of at least 64x64 px and `mask` empty or
/// CV_8UC1 of its size.
void checkExtractInput(const cv::Mat& gray, const cv::Mat& mask) {
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
}

/// What every pyramid level of one image shares.
struct ExtractionSettings {
  /// Distance of every pixel to the nearest dynamic pixel [level-0 px]; empty = no dynamic pixel.
  cv::Mat dist_to_dynamic;
  int threshold = 0;         ///< FAST score of a strong corner after the mask relaxation [grey levels]
  double sigma_dy = 0;       ///< threshold of the relaxed test [fraction of the local range]
  bool use_relaxed = false;  ///< the relaxed tier runs on this image
};

/// The mask's share, distance map and relaxed thresholds (also written into `out`); nullopt when
/// the whole image is dynamic (nothing static to describe).
std::optional<ExtractionSettings> extractionSettings(const cv::Mat& mask, const TrackingOptions& options,
                                                     OrbFeatures* out) {
  ExtractionSettings settings;
  if (!mask.empty()) {
    const int dynamic = cv::countNonZero(mask);
    out->masked_fraction = static_cast<double>(dynamic) / static_cast<double>(mask.total());
    if (dynamic == static_cast<int>(mask.total())) return std::nullopt;  // nothing static to describe
    if (dynamic > 0) {
      // AwayFromMask compares against at most the coarsest level's border.
      const double coarsest_scale = std::pow(options.scale_factor, options.num_levels - 1);
      settings.dist_to_dynamic = distanceToDynamic(mask, std::max(1.0, options.mask_border_px * coarsest_scale));
    }
  }
  settings.threshold =
      std::max(options.min_fast_threshold,
               static_cast<int>(std::lround(options.fast_threshold *
                                            (1.0 - options.mask_threshold_relaxation * out->masked_fraction))));
  out->fast_threshold_used = settings.threshold;
  settings.sigma_dy = relaxedThreshold(options.relaxed_sigma0, options.relaxed_k, out->masked_fraction);
  out->relaxed_threshold_used = settings.sigma_dy;
  // The relaxed tier is specific to dynamic masking (paper): it runs when part of the view is masked.
  settings.use_relaxed = options.relaxed_features && out->masked_fraction > 0;
  return settings;
}

/// Whether a point of a pyramid level [level px] lies at least `min_mask_distance` level-0 px
/// from the nearest dynamic pixel.
struct AwayFromMask {
  const cv::Mat& dist_to_dynamic;  ///< [level-0 px]; empty = no dynamic pixel
  cv::Size image_size;             ///< level 0 [px]
  double scale;                    ///< the level's scale
  double min_mask_distance;        ///< [level-0 px]
  bool operator()(float x, float y) const {
    if (dist_to_dynamic.empty()) return true;
    const int u = std::min(image_size.width - 1, static_cast<int>(std::lround(x * scale)));
    const int v = std::min(image_size.height - 1, static_cast<int>(std::lround(y * scale)));
    return dist_to_dynamic.at<float>(v, u) >= min_mask_distance;
  }
};

/// A level's FAST corners per grid cell (the strong ones, or the weak ones in cells without a
/// strong one), and the indices of the cells with no corner at all.
struct FastCells {
  std::vector<std::vector<cv::KeyPoint>> cells;
  std::vector<size_t> empty_cells;
};

/// FastCells of a level: corners >= `threshold` are strong, those >= `min_fast_threshold` weak.
FastCells fastCells(const cv::Mat& level_image, const LevelGrid& g, int min_fast_threshold, int threshold,
                    const AwayFromMask& is_allowed) {
  // One FAST pass per level at the low threshold; cells then take the corners scoring
  // >= `threshold` and fall back to the weaker ones (>= min_fast_threshold) only when they have
  // none (FAST's response is the largest threshold at which the pixel is still a corner).
  const int x_lo = g.x_lo, y_lo = g.y_lo, x_hi = g.x_hi, y_hi = g.y_hi;
  const cv::Rect region(x_lo - kFastBorder, y_lo - kFastBorder, x_hi - x_lo + 2 * kFastBorder,
                        y_hi - y_lo + 2 * kFastBorder);
  std::vector<cv::KeyPoint> found;
  cv::FAST(level_image(region), found, min_fast_threshold, true);
  std::vector<std::vector<cv::KeyPoint>> strong(static_cast<size_t>(g.ncols * g.nrows));
  std::vector<std::vector<cv::KeyPoint>> weak(strong.size());
  for (cv::KeyPoint kp : found) {
    kp.pt.x += static_cast<float>(region.x);
    kp.pt.y += static_cast<float>(region.y);
    if (kp.pt.x < x_lo || kp.pt.x >= x_hi || kp.pt.y < y_lo || kp.pt.y >= y_hi) continue;
    if (!is_allowed(kp.pt.x, kp.pt.y)) continue;
    const int c = std::min(g.ncols - 1, static_cast<int>((kp.pt.x - x_lo) / g.cell_w));
    const int r = std::min(g.nrows - 1, static_cast<int>((kp.pt.y - y_lo) / g.cell_h));
    const size_t index = static_cast<size_t>(r * g.ncols + c);
    (kp.response >= threshold ? strong : weak)[index].push_back(kp);
  }
  FastCells out;
  out.cells.reserve(strong.size());
  for (size_t i = 0; i < strong.size(); ++i) {
    if (!strong[i].empty()) {
      out.cells.push_back(std::move(strong[i]));
    } else if (!weak[i].empty()) {
      out.cells.push_back(std::move(weak[i]));
    } else {
      out.empty_cells.push_back(i);
    }
  }
  return out;
}

/// Relaxed-test keypoints of one grid cell of a pyramid level (level pixel coordinates).
std::vector<cv::KeyPoint> relaxedCandidates(const cv::Mat& level_image, const cv::Rect& cell, double sigma_dy,
                                            const TrackingOptions& options, const AwayFromMask& is_allowed) {
  // Candidates on a 2-px lattice (the ring has radius 3, so neighbours on the lattice share most
  // of their ring), best score first, then a 3-px non-maximum suppression inside the cell.
  std::vector<cv::KeyPoint> found;
  for (int y = cell.y; y < cell.y + cell.height; y += 2) {
    for (int x = cell.x; x < cell.x + cell.width; x += 2) {
      const RelaxedResponse r = relaxedResponse(level_image, x, y, sigma_dy);
      if (!isRelaxedFeature(r, options.relaxed_min_count, options.fast_threshold)) continue;
      if (!is_allowed(static_cast<float>(x), static_cast<float>(y))) continue;
      // Scores below every FAST corner's: relaxed features rank after FAST corners.
      found.emplace_back(static_cast<float>(x), static_cast<float>(y), 7.f, -1.f, r.score / 16.f * 1e-3f);
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

/// Up to `budget` relaxed-test keypoints of a level from the grid cells `empty_cells`, served
/// round-robin (level pixel coordinates).
std::vector<cv::KeyPoint> relaxedKeypoints(const cv::Mat& level_image, const LevelGrid& g,
                                           const std::vector<size_t>& empty_cells, double sigma_dy,
                                           const TrackingOptions& options, const AwayFromMask& is_allowed, int budget) {
  std::vector<std::vector<cv::KeyPoint>> relaxed_cells;
  for (size_t i : empty_cells) {
    std::vector<cv::KeyPoint> relaxed = relaxedCandidates(level_image, g.cellRect(i), sigma_dy, options, is_allowed);
    if (!relaxed.empty()) relaxed_cells.push_back(std::move(relaxed));
  }
  return distributeOverCells(relaxed_cells, budget);
}

/// Up to `budget` keypoints of one pyramid level (level pixel coordinates): FAST corners spread
/// over the grid, then relaxed ones for the deficit, counted into *num_relaxed.
std::vector<cv::KeyPoint> levelKeypoints(const cv::Mat& level_image, const LevelGrid& grid,
                                         const AwayFromMask& is_allowed, int budget, const ExtractionSettings& settings,
                                         const TrackingOptions& options, int* num_relaxed) {
  FastCells fast = fastCells(level_image, grid, options.min_fast_threshold, settings.threshold, is_allowed);
  std::vector<cv::KeyPoint> chosen = distributeOverCells(fast.cells, budget);
  // Relaxed features only make up a deficit left by FAST, and only in cells without a corner.
  if (settings.use_relaxed && static_cast<int>(chosen.size()) < budget) {
    const std::vector<cv::KeyPoint> extra =
        relaxedKeypoints(level_image, grid, fast.empty_cells, settings.sigma_dy, options, is_allowed,
                         budget - static_cast<int>(chosen.size()));
    *num_relaxed += static_cast<int>(extra.size());
    chosen.insert(chosen.end(), extra.begin(), extra.end());
  }
  return chosen;
}

/// Orients the keypoints of `level` (intensity centroid), scales them to level-0 px and appends
/// them to `all` (class_id = index in `all`).
void appendLevelKeypoints(const cv::Mat& level_image, int level, double scale, const std::vector<int>& umax,
                          std::vector<cv::KeyPoint>* chosen, std::vector<cv::KeyPoint>* all) {
  for (cv::KeyPoint& kp : *chosen) {
    kp.angle = intensityCentroidAngle(level_image, cvRound(kp.pt.x), cvRound(kp.pt.y), umax);
    kp.octave = level;
    kp.size = static_cast<float>(31.0 * scale);
    kp.pt.x = static_cast<float>(kp.pt.x * scale);
    kp.pt.y = static_cast<float>(kp.pt.y * scale);
    kp.class_id = static_cast<int>(all->size());
    all->push_back(kp);
  }
}

}  // namespace

OrbExtractor::OrbExtractor(const TrackingOptions& options) : options_(options) {
  options_.validate();
  const int levels = options_.num_levels;
  level_scales_.resize(static_cast<size_t>(levels));
  for (int l = 0; l < levels; ++l) {
    // Same float arithmetic as cv::ORB so that both pyramids have identical level sizes.
    level_scales_[static_cast<size_t>(l)] = static_cast<float>(std::pow(options_.scale_factor, static_cast<double>(l)));
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
    umax_[static_cast<size_t>(v)] = static_cast<int>(std::floor(std::sqrt(double(kHalfPatch * kHalfPatch - v * v))));
  }
  orb_ = cv::ORB::create(options_.num_features, static_cast<float>(options_.scale_factor), options_.num_levels, kEdgePx,
                         0, 2, cv::ORB::FAST_SCORE, 31, options_.fast_threshold);
}

OrbFeatures OrbExtractor::extract(const cv::Mat& gray, const cv::Mat& mask) {
  checkExtractInput(gray, mask);
  OrbFeatures out;
  const std::optional<ExtractionSettings> settings = extractionSettings(mask, options_, &out);
  if (!settings) return out;

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
    const std::optional<LevelGrid> grid = levelGrid(level_image.size(), kEdgePx, options_.grid_cell_px);
    if (!grid) break;  // level too small for a patch
    const AwayFromMask is_allowed{settings->dist_to_dynamic, gray.size(), scale,
                                  std::max(1.0, options_.mask_border_px * scale)};
    const int budget = features_per_level_[static_cast<size_t>(level)];
    std::vector<cv::KeyPoint> chosen =
        levelKeypoints(level_image, *grid, is_allowed, budget, *settings, options_, &out.num_relaxed);
    appendLevelKeypoints(level_image, level, scale, umax_, &chosen, &all);
  }
  if (all.empty()) return out;
  // cv::ORB computes rBRIEF on its own copy of the pyramid (Gaussian-blurred), using our angles.
  orb_->compute(gray, all, out.descriptors);
  out.keypoints = std::move(all);
  if (static_cast<int>(out.keypoints.size()) != out.descriptors.rows) {
    throw std::logic_error("OrbExtractor: cv::ORB::compute returned " + std::to_string(out.descriptors.rows) +
                           " descriptors for " + std::to_string(out.keypoints.size()) + " keypoints");
  }
  return out;
}

}  // namespace tracking
}  // namespace dypho
