#pragma once
/// \file keyframe_point_fuser.h
/// ORB-SLAM's fuse step for RGB-D keyframes: a new keyframe's points are projected into its
/// covisible keyframes and theirs into it. A matching feature that already has a point is the
/// same scene point twice (the two are merged); one without a point observes it. Without it,
/// every keyframe makes its own copy of each point that tracking did not match at that frame, so
/// few points are seen by two keyframes and bundle adjustment has little to average.

#include <cstdint>

#include "dypho/tracking/pinhole.h"
#include "dypho/tracking/tracker_map.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// What fuseKeyframePoints changed.
struct FuseStats {
  int merged = 0;  ///< duplicate points merged into one [count]
  int added = 0;   ///< observations added to points by keyframe features that had none [count]
};

/// Fuses the points of keyframe `keyframe_id` with those of its fuse_keyframes most covisible
/// keyframes, both ways. Only trusted points are projected: past probation (TrackerMap::isVerified)
/// and never seen on a moving surface (MapPoint::num_on_dynamic == 0), so that a person the mask
/// missed is not merged into the static map; a feature whose point was seen on a moving surface
/// is left alone. A point is matched to the target keyframe's feature within
/// fuse_radius_px (times the point's level scale) of its projection, at most
/// max_level_difference levels from its own, with a depth within fuse_max_depth_ratio of the
/// projected one and the smallest Hamming distance, at most fuse_max_hamming_distance. The
/// merged point keeps the position of the trusted one when the other is on probation, else of the
/// one with more observations (the older on a tie). A
/// point that gained views takes the descriptor, keypoint and reference distance of its most
/// typical view (the least median Hamming distance to the others, ORB-SLAM's distinctive
/// descriptor). Nothing happens when fuse_keyframes is 0 or the keyframe is unknown.
FuseStats fuseKeyframePoints(TrackerMap* map, std::int64_t keyframe_id, const Pinhole& pinhole,
                             const TrackingOptions& options);

}  // namespace tracking
}  // namespace dypho
