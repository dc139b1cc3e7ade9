#pragma once
/// \file tracking_conversions.h
/// The tracking nodelet's messages from core types (pure functions): the status, the timing and
/// the REP-105 transforms. The shared image, pose and keyframe conversions are in
/// dypho_ros/conversions.h.

#include <string>
#include <vector>

#include <dypho_slam/StageTiming.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <std_msgs/Header.h>

#include "dypho/tracking/live_tracker.h"
#include "dypho/tracking/tracking_stage.h"

namespace dypho::tracking_ros {

std::uint8_t toStatusMaskSource(tracking::MaskSource source);
std::uint8_t toStatusState(tracking::TrackingState state);

/// The status of one tracked frame: state, counts, pose and its flags, and this frame's live
/// figures (mask source, wait, work). `header.frame_id` becomes `camera_frame`. The rolling
/// figures and the counters are the caller's (fillLiveCounters()).
dypho_slam::TrackingStatus toStatusMsg(const tracking::TrackingOutput& out, const std_msgs::Header& header,
                                       const std::string& camera_frame, tracking::MaskSource source,
                                       const tracking::LiveFrameFigures& live);

/// The live tracker's counters and rolling figures into `status`.
void fillLiveCounters(dypho_slam::TrackingStatus& status, const tracking::LiveCounters& counters,
                      const tracking::LiveStatistics& statistics);

/// The frame's pose in `header`'s frame (the map) with its PoseCovariance, row-major in ROS's
/// order (x, y, z, rotation about x, y, z); call only when result.pose_covariance.valid.
geometry_msgs::PoseWithCovarianceStamped toPoseWithCovarianceMsg(const tracking::TrackingResult& result,
                                                                 const std_msgs::Header& header);

/// The tracker's stage times of one frame.
dypho_slam::StageTiming toTimingMsg(const tracking::TrackingResult& result, const std_msgs::Header& header);

/// REP-105: map -> odom (TrackingOutput::T_map_odom: loop corrections and relocalisation jumps)
/// and odom -> camera (the smooth odometry); empty when either is not finite.
std::vector<geometry_msgs::TransformStamped> toTfMsgs(const Eigen::Isometry3d& T_map_camera,
                                                      const Eigen::Isometry3d& T_map_odom, const ros::Time& stamp,
                                                      const std::string& map_frame, const std::string& odom_frame,
                                                      const std::string& camera_frame);

}  // namespace dypho::tracking_ros
