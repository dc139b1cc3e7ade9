/// The tracking nodelet's messages from core types.
#include "tracking_conversions.h"

#include "dypho_ros/conversions.h"

namespace dypho::tracking_ros {

namespace rc = dypho::ros_conversions;

std::uint8_t toStatusMaskSource(tracking::MaskSource source) {
  switch (source) {
    case tracking::MaskSource::kMatched:
      return dypho_slam::TrackingStatus::MASK_MATCHED;
    case tracking::MaskSource::kCarried:
      return dypho_slam::TrackingStatus::MASK_CARRIED;
    default:
      return dypho_slam::TrackingStatus::MASK_NONE;
  }
}

std::uint8_t toStatusState(tracking::TrackingState state) {
  switch (state) {
    case tracking::TrackingState::kOk:
      return dypho_slam::TrackingStatus::OK;
    case tracking::TrackingState::kLost:
      return dypho_slam::TrackingStatus::LOST;
    default:
      return dypho_slam::TrackingStatus::NOT_INITIALIZED;
  }
}

dypho_slam::TrackingStatus toStatusMsg(const tracking::TrackingOutput& out, const std_msgs::Header& header,
                                       const std::string& camera_frame, tracking::MaskSource source,
                                       const tracking::LiveFrameFigures& live) {
  const tracking::TrackingResult& result = out.result;
  dypho_slam::TrackingStatus status;
  status.header = header;
  status.header.frame_id = camera_frame;
  status.state = toStatusState(result.state);
  status.is_keyframe = result.is_keyframe;
  status.num_features = result.num_features;
  status.num_inliers = result.num_inliers;
  status.masked_fraction = static_cast<float>(result.masked_fraction);
  status.message = result.message;
  status.T_world_camera = rc::toPoseMsg(out.pose.T_world_camera);
  status.trusted = out.pose.trusted;
  status.anchored = out.pose.anchored;
  status.discontinuous = out.pose.discontinuous;
  status.restarted = out.restarted;
  status.T_correction = rc::toPoseMsg(out.pose.T_correction);
  status.mask_source = toStatusMaskSource(source);
  status.mask_wait_ms = static_cast<float>(live.mask_wait_ms);
  status.tracking_ms = static_cast<float>(live.tracking_ms);
  status.caught_up = live.caught_up;
  return status;
}

geometry_msgs::PoseWithCovarianceStamped toPoseWithCovarianceMsg(const tracking::TrackingResult& result,
                                                                 const std_msgs::Header& header) {
  geometry_msgs::PoseWithCovarianceStamped msg;
  msg.header = header;
  msg.pose.pose = rc::toPoseMsg(result.T_world_camera);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c)
      msg.pose.covariance[static_cast<std::size_t>(6 * r + c)] = result.pose_covariance.world(r, c);
  }
  return msg;
}

void fillLiveCounters(dypho_slam::TrackingStatus& status, const tracking::LiveCounters& counters,
                      const tracking::LiveStatistics& statistics) {
  status.tracking_p50_ms = static_cast<float>(statistics.tracking_p50_ms);
  status.tracking_p95_ms = static_cast<float>(statistics.tracking_p95_ms);
  status.input_rate_hz = static_cast<float>(statistics.input_rate_hz);
  status.frames_in = counters.frames_in;
  status.frames_processed = counters.frames_processed;
  status.frames_dropped = counters.frames_dropped;
  status.frames_mask_carried = counters.frames_mask_carried;
  status.frames_without_mask = counters.frames_without_mask;
  status.frames_caught_up = counters.frames_caught_up;
}

dypho_slam::StageTiming toTimingMsg(const tracking::TrackingResult& result, const std_msgs::Header& header) {
  dypho_slam::StageTiming timing;
  timing.header = header;
  timing.node = "tracking";
  timing.stages = {"features", "matching", "pnp", "refine", "local_ba", "loop", "relocalization"};
  timing.ms = {static_cast<float>(result.times.features),      static_cast<float>(result.times.matching),
               static_cast<float>(result.times.pnp),           static_cast<float>(result.times.refine),
               static_cast<float>(result.times.local_ba),      static_cast<float>(result.times.loop),
               static_cast<float>(result.times.relocalization)};
  timing.total_ms = static_cast<float>(result.times.total);
  return timing;
}

namespace {

geometry_msgs::TransformStamped toTransform(const Eigen::Isometry3d& T, const ros::Time& stamp,
                                            const std::string& parent, const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  const geometry_msgs::Pose p = rc::toPoseMsg(T);
  t.transform.translation.x = p.position.x;
  t.transform.translation.y = p.position.y;
  t.transform.translation.z = p.position.z;
  t.transform.rotation = p.orientation;
  return t;
}

}  // namespace

std::vector<geometry_msgs::TransformStamped> toTfMsgs(const Eigen::Isometry3d& T_map_camera,
                                                      const Eigen::Isometry3d& T_map_odom, const ros::Time& stamp,
                                                      const std::string& map_frame, const std::string& odom_frame,
                                                      const std::string& camera_frame) {
  const Eigen::Isometry3d T_odom_camera = T_map_odom.inverse() * T_map_camera;
  if (!T_odom_camera.matrix().allFinite() || !T_map_odom.matrix().allFinite()) return {};
  return {toTransform(T_map_odom, stamp, map_frame, odom_frame),
          toTransform(T_odom_camera, stamp, odom_frame, camera_frame)};
}

}  // namespace dypho::tracking_ros
