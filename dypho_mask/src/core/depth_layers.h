#pragma once
/// \file depth_layers.h
/// Steps of cutRegionsToDepthLayers (box_depth_segmenter.h) that are tested alone (not installed,
/// not part of the API).

#include <vector>

#include <opencv2/core.hpp>

namespace dypho {
namespace mask {
namespace internal {

/// The far depth of every labelled region (95th percentile of its depths > 0; 0 without any):
/// the background behind its objects. `regions`: CV_32S labels 0..num_regions-1 (0 = none),
/// `depth_m` CV_32FC1 [m] of the same size. Index = label; entry 0 is 0.
std::vector<float> regionFarDepths(const cv::Mat& depth_m, const cv::Mat& regions, int num_regions);

}  // namespace internal
}  // namespace mask
}  // namespace dypho
