#pragma once
/// \file mask_options_fields.h
/// The list of FlowMaskOptions keys, written once: parameter readers (ROS private params, YAML
/// files) and printers visit the fields through `visitOptions`. Keep it in the order of the struct.

#include "dypho/mask/flow_mask_options.h"

namespace dypho::mask {

/// Calls `visitor(key, field, doc)` for every field of `options`.
template <typename Visitor>
void visitOptions(FlowMaskOptions& options, Visitor&& visitor) {
  visitor("flow_scale", options.flow_scale, "Dense flow is computed at this fraction of the input resolution, in (0, 1]. Default 0.25 (640x480 -> 160x120).");
  visitor("residual_threshold_px", options.residual_threshold_px, "A pixel is dynamic when its flow differs from the camera-induced global motion by more than this [full-res px], > 0. Default 2.0.");
  visitor("min_region_area_px", options.min_region_area_px, "Connected dynamic regions smaller than this [full-res px^2] are dropped, >= 0. Default 400.");
  visitor("dilate_px", options.dilate_px, "Safety margin grown around the final mask [full-res px], >= 0. Default 8.");
  visitor("max_masked_fraction", options.max_masked_fraction, "Above this masked fraction of the image (in (0, 1]) the global-motion model is considered wrong: the result is an empty mask with `degraded = true`. Default 0.6.");
  visitor("open_radius_px", options.open_radius_px, "Radius of the morphological opening that removes speckles [full-res px], >= 0 (0 = none). Default 4.");
  visitor("sample_step_px", options.sample_step_px, "Spacing of the grid of flow samples used to fit the global motion [full-res px], >= 1. Default 16 (1200 samples at 640x480).");
  visitor("ransac_threshold_px", options.ransac_threshold_px, "RANSAC inlier threshold of the global homography fit [full-res px], > 0. Default 1.0.");
  visitor("ransac_max_iterations", options.ransac_max_iterations, "RANSAC iterations of the global homography fit, >= 1. Default 500.");
  visitor("min_inlier_ratio", options.min_inlier_ratio, "Minimum fraction of grid samples that must agree with the global motion, in [0, 1); below it the fit is not trusted and the result is degraded. Default 0.3.");
  visitor("min_texture_gradient", options.min_texture_gradient, "Flow in textureless regions (blank walls, saturated or black surfaces) is not measured but interpolated, so its residual is no evidence of motion. A flow pixel counts as textured when the RMS grey-lev");
  visitor("ultrafast", options.ultrafast, "Use OpenCV's DIS PRESET_ULTRAFAST instead of PRESET_FAST (faster, noisier). Default false.");
}

}  // namespace dypho::mask
