#pragma once
/// \file tracker_map.h
/// Keyframes and map points with their observations and covisibility: the map tracking works on.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/types.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/rolling_shutter_error.h"
#include "dypho/tracking/tracking_options.h"

namespace dypho {
namespace tracking {

/// A 3D point of the map, seen by one or more keyframes.
struct MapPoint {
  std::int64_t id = -1;                                 ///< unique map-point id
  Eigen::Vector3d p_world_m = Eigen::Vector3d::Zero();  ///< position in the world [m]
  cv::Mat descriptor;                                   ///< 1 x 32 CV_8UC1 ORB descriptor (first observation)
  cv::KeyPoint keypoint;                                ///< keypoint of the first observation (level, angle)
  double reference_distance_m = 0;                      ///< distance camera -> point at the first observation [m]
  std::int64_t first_keyframe_id = -1;                  ///< keyframe that created the point
  std::map<std::int64_t, int> observations;             ///< keyframe id -> keypoint index in that keyframe
  int num_visible = 0;  ///< frames in whose local map the point was projected into the image [count]
  int num_found = 0;    ///< frames where it was a pose inlier [count]
  /// tracked frames that saw it on a dynamic surface (TrackerMap::cullMovingPoints) [count]
  int num_on_dynamic = 0;
  /// of those, frames in which the camera was still [count]
  int num_on_dynamic_still = 0;
  /// Probation (TrackingOptions::point_probation_frames): tracked frames on which the point, not
  /// yet verified, agreed with the pose [count]; verified from point_probation_frames on.
  int num_confirmed = 0;
  /// Tracked frames on which the unverified point disagreed with the verified points' pose [count].
  int num_refuted = 0;
};

/// A keyframe as the map stores it: its features (undistorted, with depth) and their map points.
struct MapKeyframe {
  std::int64_t id = -1;                                              ///< keyframe id
  Timestamp stamp_ns = 0;                                            ///< frame stamp [ns]
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();  ///< pose (changed by BA / loops)
  FrameFeatures features;                                            ///< keypoints, undistorted px, depth, 3D in camera
  std::vector<std::int64_t> map_point_ids;                           ///< per feature: its map point id (-1 = culled)
  /// Motion blur of the keyframe's image: the camera's velocities during its frame and the
  /// exposure its keypoints are weighted with in bundle adjustment (motion_blur.h) [s]; 0 = sharp.
  CameraRates blur_rates;
  double blur_exposure_s = 0.0;
  // The keyframe's images are handed to mapping and not kept here: nothing in tracking reads
  // them, and a long run would otherwise hold every keyframe's images (2.4 MB each at 640x480).
};

/// Where a removed keyframe is (TrackerMap::removeKeyframe): its pose relative to a keyframe still
/// in the map, so that its pose follows later corrections of that keyframe.
struct RemovedKeyframe {
  std::int64_t parent_id = -1;                                          ///< keyframe still in the map
  Eigen::Isometry3d T_parent_keyframe = Eigen::Isometry3d::Identity();  ///< removed keyframe in the parent
};

/// Everything a TrackerMap holds, in id order (TrackerMap::state / restore): what a tracker
/// session file stores (tracker_session.h). Covisibility needs nothing here: it is computed
/// from the points' observations.
struct TrackerMapState {
  std::map<std::int64_t, MapKeyframe> keyframes;    ///< keyframe id -> keyframe
  std::map<std::int64_t, MapPoint> points;          ///< map-point id -> point
  std::map<std::int64_t, RemovedKeyframe> removed;  ///< removed keyframe id -> where it is
  std::int64_t next_point_id = 0;                   ///< next free map-point id (above every id in use)
};

/// True when `T` is a finite rigid transform: its rotation orthonormal within 1e-6, determinant
/// positive, last row 0 0 0 1 (what every pose of a map is; a session file is checked for it).
bool isRigidPose(const Eigen::Isometry3d& T);

/// The first reason `state` cannot be a map, empty when it can: a keyframe whose feature arrays
/// differ in length or hold non-finite numbers, a descriptor that is not 32 bytes, an observation
/// of an unknown keyframe or of a feature index it does not have, an id that does not match its
/// key or is not below next_point_id, a pose that is not rigid (isRigidPose), a non-finite
/// point. What a session file is checked for after its checksum, so that no later step of
/// tracking indexes out of range.
std::string trackerMapStateProblem(const TrackerMapState& state);

/// The tracker's global map: every keyframe and map point of the run (the sparse counterpart of
/// the Gaussian map). Tracking works on views of it: the local map of the reference keyframe
/// (localPoints) and one keyframe's own points (keyframePoints). Map points are created from the keyframe's depth
/// (RGB-D: each feature with valid depth is a metric point at once); a feature matched to an existing map point as a
/// pose inlier adds an observation to that point instead (ids passed in map_point_ids).
///
/// Covisibility: two keyframes are covisible when they observe >= covisibility_min_shared common
/// map points; weights are computed on demand from the observations (no cached graph to keep in
/// sync). The *local map* of a keyframe is the union of the points of that keyframe and its
/// local_map_keyframes most covisible keyframes.
///
/// Culling (ORB-SLAM style): a point is removed once it was predicted visible in >= 10 frames
/// but found in fewer than cull_min_found_ratio of them; observations pointing to it are cleared.
/// A keyframe is redundant when at least keyframe_cull_redundant_ratio of its map points are seen
/// by >= 3 other keyframes at the same or a finer scale; removing it (removeKeyframe) keeps its
/// pose relative to a remaining keyframe, so keyframePose still answers for it (a trajectory that
/// refers to it follows later corrections) while its features and observations are freed.
class TrackerMap {
 public:
  /// Uses local_map_keyframes, local_map_nearby_*, covisibility_min_shared, cull_min_found_ratio,
  /// scale_factor.
  explicit TrackerMap(const TrackingOptions& options);

  /// Adds a keyframe. map_point_ids[i] >= 0 and known -> observation of that point; otherwise a
  /// new point with the id `map_point_ids[i]` (or a new id when -1) at T_world_camera * p_camera.
  /// Returns the final ids (same length as the features).
  std::vector<std::int64_t> addKeyframe(MapKeyframe keyframe);

  /// Keyframe ids sorted by the number of shared map points, most first, at most max_count, each
  /// sharing >= covisibility_min_shared points with `keyframe_id`. The keyframe itself is excluded.
  std::vector<std::int64_t> covisibleKeyframes(std::int64_t keyframe_id, int max_count) const;

  /// Number of map points observed by both keyframes.
  int sharedPoints(std::int64_t a, std::int64_t b) const;

  /// The local map around `keyframe_id` as KeyframePoints (one entry per map point, no
  /// duplicates; `keyframe` = that keyframe's published keyframe; reference_distance_m filled).
  KeyframePoints localPoints(std::int64_t keyframe_id) const;

  /// Keyframes that look at the same part of the scene as `keyframe_id` (optical axes within
  /// local_map_nearby_max_angle_deg, centres within local_map_nearby_max_distance_m), with ids >=
  /// `min_id` and not in `exclude`: the closest view first (angle between the axes [deg] plus
  /// 1 per cm between the centres; ties: the older first), at most local_map_nearby_keyframes.
  std::vector<std::int64_t> nearbyKeyframes(std::int64_t keyframe_id, const std::vector<std::int64_t>& exclude,
                                            std::int64_t min_id) const;

  /// The local map tracking matches against: localPoints' keyframes and the nearbyKeyframes of
  /// `keyframe_id` with ids >= `min_nearby_id` (a segment not yet tied to the earlier map passes
  /// its first keyframe: the earlier keyframes' poses are in another frame).
  KeyframePoints trackingPoints(std::int64_t keyframe_id, std::int64_t min_nearby_id) const;

  /// Only the points observed by `keyframe_id` (for descriptor search in relocalisation / loops).
  KeyframePoints keyframePoints(std::int64_t keyframe_id) const;

  /// Fuses map point `remove_id` into `keep_id` (loop closure: the same scene point seen again):
  /// keyframes observing `remove_id` observe `keep_id` instead (unless they already do); then
  /// `remove_id` is erased. False when either is unknown or they are equal.
  bool mergePoints(std::int64_t keep_id, std::int64_t remove_id);

  /// Keyframe `keyframe_id`'s feature `feature_index` observes point `point_id` (fuse step).
  /// False, and nothing changes, when either is unknown, the index is out of range, the feature
  /// already has a point or the keyframe already observes this one.
  bool addObservation(std::int64_t point_id, std::int64_t keyframe_id, int feature_index);

  /// Sets the keyframe poses to `T_world_keyframe` and moves every map point rigidly with the
  /// correction of its first keyframe (T_new * T_old^-1). Unknown ids are ignored.
  void applyKeyframePoses(const std::map<std::int64_t, Eigen::Isometry3d>& T_world_keyframe);

  /// Bookkeeping after a tracked frame: `visible` map-point ids were projected into the image,
  /// `found` were pose inliers.
  void updateVisibility(const std::vector<std::int64_t>& visible, const std::vector<std::int64_t>& found);

  /// Removes bad points (see class comment); returns how many.
  int cullPoints();

  /// Counts one more sighting on a dynamic surface for each id in `on_dynamic` (and, when
  /// `camera_still`, one more while the camera was still), then removes every point seen so at
  /// least `min_hits` times and at least as often as it was a pose inlier (a moving point, not a
  /// static one the mask happened to cover). With `still_only` only the sightings while the
  /// camera was still count for the removal. Returns the removed points' ids.
  std::vector<std::int64_t> cullMovingPoints(const std::vector<std::int64_t>& on_dynamic, int min_hits,
                                             bool camera_still = true, bool still_only = false);
  /// Removes the points of `ids` that keyframe `keyframe_id` created and that were seen on a
  /// dynamic surface at least `min_hits` times (MapPoint::num_on_dynamic), whatever their pose
  /// inlier count: the unverified points of a first keyframe. Returns the removed ids.
  std::vector<std::int64_t> removePointsCreatedBy(std::int64_t keyframe_id, const std::vector<std::int64_t>& ids,
                                                  int min_hits);
  /// Probation bookkeeping after a tracked frame: one more agreement for each id in `confirmed`,
  /// one more disagreement for each in `refuted`; removes the points with
  /// point_probation_max_refuted disagreements that are not verified yet. Returns the removed ids.
  std::vector<std::int64_t> updateProbation(const std::vector<std::int64_t>& confirmed,
                                            const std::vector<std::int64_t>& refuted);
  /// True when the point carries the pose (probation passed or off); false when unknown.
  bool isVerified(std::int64_t point_id) const;

  /// True when the keyframe is redundant (see class comment, ratio in (0, 1]); false when
  /// unknown or it has no map points.
  bool isRedundant(std::int64_t keyframe_id, double redundant_ratio) const;

  /// Removes a keyframe: its observations are cleared (points seen by no other keyframe are
  /// erased, points it created are handed to their oldest remaining observer) and its pose is
  /// kept relative to its most covisible remaining keyframe (else the newest). False when unknown
  /// or it is the only keyframe.
  bool removeKeyframe(std::int64_t keyframe_id);

  /// Current pose of a keyframe, also of a removed one (through the keyframe it was attached to);
  /// nullopt when never known or forgotten by clear().
  std::optional<Eigen::Isometry3d> keyframePose(std::int64_t keyframe_id) const;

  /// Number of removed keyframes whose poses are still answered.
  std::size_t numRemovedKeyframes() const { return removed_.size(); }

  /// Keyframe by id or nullptr.
  const MapKeyframe* keyframe(std::int64_t id) const;
  /// Map point by id or nullptr.
  const MapPoint* point(std::int64_t id) const;
  /// Mutable access for optimisers (bundle adjustment, loop correction).
  MapKeyframe* mutableKeyframe(std::int64_t id);
  /// Mutable access for optimisers.
  MapPoint* mutablePoint(std::int64_t id);

  /// All keyframes, ordered by id.
  const std::map<std::int64_t, MapKeyframe>& keyframes() const { return keyframes_; }
  /// All map points by id.
  const std::unordered_map<std::int64_t, MapPoint>& points() const { return points_; }
  /// Next free map-point id.
  std::int64_t nextPointId() const { return next_point_id_; }
  /// Forgets everything (ids keep increasing).
  void clear();
  /// A copy of everything the map holds (for a session file).
  TrackerMapState state() const;
  /// Replaces everything with `state` (a session file's map); the next point id is the larger
  /// of the state's and the current one. Throws std::invalid_argument with
  /// trackerMapStateProblem's reason and leaves the map unchanged when `state` cannot be a map.
  void restore(TrackerMapState state);

 private:
  /// Sets the point's slot in every keyframe that observes it to -1 (before erasing it).
  void detachObservations(const MapPoint& p);
  /// `keyframe_id` and its local_map_keyframes most covisible keyframes (localPoints' keyframes).
  std::vector<std::int64_t> localKeyframes(std::int64_t keyframe_id) const;
  /// Points of the keyframes `kfs` without duplicates; `keyframe` of the result = keyframe_id's.
  KeyframePoints collectPoints(std::int64_t keyframe_id, const std::vector<std::int64_t>& kfs) const;

  TrackingOptions options_;
  std::map<std::int64_t, MapKeyframe> keyframes_;
  std::unordered_map<std::int64_t, MapPoint> points_;
  std::unordered_map<std::int64_t, RemovedKeyframe> removed_;
  std::int64_t next_point_id_ = 0;
};

}  // namespace tracking
}  // namespace dypho
