#pragma once
/// \file keyframe_evaluation.h
/// Map quality at the training keyframes: PSNR on static pixels and depth L1.

#include <cstddef>
#include <vector>

namespace dypho::mapping {

/// PSNR and depth error of the map rendered at the stored keyframes (training resolution).
struct KeyframeEvaluation {
  std::size_t num_keyframes = 0;         ///< keyframes evaluated
  std::size_t num_keyframes_stored = 0;  ///< keyframes with images (more than evaluated past a time budget)
  /// Mean over keyframes of the PSNR on static pixels [dB]; with exposure_compensation the
  /// rendered colour goes through the keyframe's exposure first (exp(k) * rendered + b).
  double psnr_db = 0.0;
  double psnr_without_exposure_db = 0.0;     ///< the same with the plain rendered colour [dB]
  double depth_l1_m = 0.0;                   ///< mean |Dr - D| over static pixels with valid depth [m]
  std::vector<double> psnr_per_keyframe_db;  ///< in keyframe order
};

}  // namespace dypho::mapping
