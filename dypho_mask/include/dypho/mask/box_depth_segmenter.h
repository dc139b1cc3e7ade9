#pragma once
/// \file box_depth_segmenter.h
/// Turns a detection box into a pixel mask with the depth image: the foreground depth cluster
/// inside the box, so a box never masks the wall behind the object.

#include <opencv2/core.hpp>

namespace dypho {
namespace mask {

/// Settings of `paintBoxForeground`.
struct BoxDepthSettings {
  /// Depth extent of the object behind its nearest well-populated depth [m], > 0 (a person with
  /// swinging arms is about 0.6 m deep).
  double depth_range_m = 0.6;
  /// The foreground cluster is the nearest depth window of `depth_range_m` that holds at least
  /// this share of the box's valid depths, in (0, 1].
  double min_cluster_share = 0.15;
  /// Boxes with fewer valid depths than this share are painted whole (no depth to segment),
  /// in [0, 1].
  double min_valid_share = 0.05;
};

/// ORs 255 into `mask_image` (CV_8UC1, image size) on the foreground of `box` (image pixels):
/// pixels with depth in [d_near - 0.1 m, d_near + depth_range_m], where d_near starts the nearest
/// depth window holding min_cluster_share of the box's valid depths, closed (5x5) so depth holes
/// inside the object are included. `depth_m`: CV_32FC1 [m] of the image size, or empty (depth-free
/// mode: the whole box is painted, as when too few depths are valid). Returns true when depth
/// was used, false when the whole box was painted.
bool paintBoxForeground(const cv::Mat& depth_m, const cv::Rect& box, const BoxDepthSettings& settings,
                        cv::Mat& mask_image);

/// Cuts every 8-connected region of `mask` (CV_8UC1, non-zero = dynamic; modified in place) to
/// its foreground depth cluster, the same rule as for boxes: removes the halo that reduced-
/// resolution flow leaves on the background around a moving object. Pixels without depth stay.
/// Regions with too few valid depths stay whole. `depth_m`: CV_32FC1 of the mask's size.
void cutRegionsToDepthForeground(const cv::Mat& depth_m, const BoxDepthSettings& settings, cv::Mat& mask);

/// cutRegionsToDepthForeground for crowds, where one flow region spans several people at
/// different depths: after the nearest layer, up to `max_layers` - 1 farther layers are kept
/// too. A farther layer is the nearest depth cluster of what is left of a region, where that
/// part is wider than `halo_px` (erosion; the halo on the background is a band about as wide as
/// the flow's margin) and lies more than 0.3 m in front of the original region's far depth (its
/// 95th percentile: the background behind the people). Pixels without depth stay as in the
/// nearest-layer cut. `nearest_layer` (optional): receives the nearest-layer cut alone.
void cutRegionsToDepthLayers(const cv::Mat& depth_m, const BoxDepthSettings& settings, int halo_px, int max_layers,
                             cv::Mat& mask, cv::Mat* nearest_layer = nullptr);

/// Settings of `growRegionsInDepth`.
struct DepthGrowSettings {
  /// Extent of an object's depth cluster (see BoxDepthSettings::depth_range_m) [m], > 0.
  double depth_range_m = 0.6;
  /// Largest depth step between 4-neighbours on one surface: max_step_m + max_step_rel * depth [m].
  double max_step_m = 0.05;
  double max_step_rel = 0.03;
  /// A pixel is explained by the background (and never grown into) when the prior background
  /// depth is valid and depth >= prior - sigma_m [m].
  double sigma_m = 0.2;
  /// Regions with fewer pixels with depth than this do not grow (speckles the clean-up drops
  /// anyway must not spread) [px at the mask's resolution], >= 0.
  int min_seed_area_px = 100;
  /// A region grows to at most this many times its own area [ratio], >= 0 (0 = no limit). One
  /// that would grow further is not grown at all: it lies on a surface that reaches far beyond
  /// it (a desk, a floor or a wall the flow misjudged on a fast turn while the background has no
  /// value yet), not on an object whose inside it fills.
  double max_growth_ratio = 0.0;
};

/// Grows every 8-connected region of `mask` (CV_8UC1, non-zero = dynamic, in place; 255 written)
/// over the object's surface: a 4-neighbour joins when its depth lies in the region's foreground
/// cluster (same rule as cutRegionsToDepthForeground), differs from the pixel it is reached from
/// by at most the step, and the background does not explain it (`background_m` CV_32FC1, 0 = no
/// value). Fills the textureless inside of a person whose outline the flow found where the
/// background model has no value yet (new view, person entering or standing since the start).
/// A region that would grow beyond max_growth_ratio times its area keeps its own pixels only.
/// Pixels without depth are never grown into. `depth_m` CV_32FC1 of the mask's size.
void growRegionsInDepth(const cv::Mat& depth_m, const cv::Mat& background_m, const DepthGrowSettings& settings,
                        cv::Mat& mask);

}  // namespace mask
}  // namespace dypho
