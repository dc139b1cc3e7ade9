#pragma once
/// \file map_views.h
/// Scores a saved Gaussian map over a sequence (view_evaluation.h): every Nth frame of the input
/// is read again, posed from a trajectory (the runner's trajectory.txt, or the graph's), rendered
/// and compared on its static pixels. Shared by dypho_run_dataset and dypho_evaluate_map.

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/trajectory_io.h"
#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/view_evaluation.h"
#include "dypho/tools/frame_source.h"

namespace dypho::tools {

/// The dynamic mask of frame `index` (CV_8UC1, 255 = dynamic), or empty: all pixels are scored.
using ViewMaskLookup = std::function<cv::Mat(std::size_t index, Timestamp stamp_ns)>;

/// What a map was scored on, beyond the scores.
struct MapViewRun {
  mapping::ViewEvaluation evaluation;
  std::size_t frames_chosen = 0;        ///< every Nth frame of the first `num_frames`
  std::size_t frames_without_pose = 0;  ///< chosen but absent from the trajectory (not scored)
  std::size_t frames_unreadable = 0;    ///< chosen but their files could not be read
  std::size_t frames_without_mask = 0;  ///< scored on all their pixels (the lookup had no mask)
  /// The counts in one line (for the summary and view_evaluation.txt readers).
  std::string notes() const;
};

/// Frames 0, N, 2N, ... below `num_frames` of `source`, each posed at the trajectory's pose with
/// the same stamp (within 1 ms; frames without one are counted and skipped), rendered from `map`
/// through the frame's camera and scored against it with the mask from `mask_of`. A frame is a
/// keyframe view when a stamp of `keyframe_stamps_s` lies within 1 ms. `num_threads` >= 1.
MapViewRun evaluateMapViews(const mapping::GaussianMap& map, const FrameSource& source, std::size_t num_frames,
                            const std::vector<StampedPose>& trajectory, const std::vector<double>& keyframe_stamps_s,
                            const ViewMaskLookup& mask_of, const mapping::ViewEvaluationOptions& options,
                            int num_threads);

/// Reads the masks of a --save-masks folder (OUT/mask.txt + OUT/mask/*.png) into a lookup by
/// stamp (within 1 ms). Throws std::runtime_error when mask.txt is missing or names a missing file.
ViewMaskLookup masksFromFolder(const std::string& dir);

}  // namespace dypho::tools
