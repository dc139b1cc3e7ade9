/// RgbdOdometry's state as a session (tracker_session.h): taken at a save, restored at a resume.
#include <algorithm>
#include <stdexcept>
#include <utility>

#include "dypho/tracking/rgbd_odometry.h"

namespace dypho {
namespace tracking {

TrackerSession RgbdOdometry::session() const {
  if (map_.keyframes().empty() || !has_pinhole_) {
    throw std::logic_error("RgbdOdometry::session: no keyframe yet, there is no session to save");
  }
  TrackerSession session;
  session.camera = camera_;
  session.map = map_.state();
  session.next_keyframe_id = next_keyframe_id_;
  session.last_loop_keyframe_id = last_loop_keyframe_id_;
  session.unanchored_from_keyframe_id = unanchored_from_keyframe_id_;
  session.last_stamp_ns = last_stamp_ns_;
  session.T_world_last = T_world_last_;
  session.T_world_odom = T_world_odom_;
  session.reported_poses = reported_poses_;
  return session;
}

void RgbdOdometry::restoreSession(TrackerSession session) {
  const std::string problem = trackerSessionProblem(session);
  if (!problem.empty()) throw std::invalid_argument("RgbdOdometry::restoreSession: " + problem);
  reset();
  map_.restore(std::move(session.map));
  camera_ = session.camera;
  pinhole_ = Pinhole::fromIntrinsics(camera_);
  has_pinhole_ = true;
  next_keyframe_id_ = std::max(next_keyframe_id_, session.next_keyframe_id);
  last_loop_keyframe_id_ = session.last_loop_keyframe_id;
  unanchored_from_keyframe_id_ = session.unanchored_from_keyframe_id;
  T_world_last_ = session.T_world_last;
  T_world_odom_ = session.T_world_odom;
  reported_poses_ = std::move(session.reported_poses);
  // Kept for the next save, not as a gate: the next frame may have any stamp (has_stamp_ false).
  last_stamp_ns_ = session.last_stamp_ns;
  // The newest keyframe is the reference until relocalisation finds the camera (the result's
  // reference fields while lost, the pose of a re-initialisation).
  setReference(map_.keyframes().rbegin()->first);
  searching_map_ = true;
}

}  // namespace tracking
}  // namespace dypho
