/// OdomFrame: map -> odom takes the pose's jumps, odom -> camera stays smooth (REP-105).
#include "dypho/tracking/odom_frame.h"

namespace dypho::tracking {

Eigen::Isometry3d OdomFrame::update(const Eigen::Isometry3d& T_map_camera, const Eigen::Isometry3d& T_map_odom_tracker,
                                    bool jumped) {
  const Eigen::Isometry3d T_trackerodom_camera = T_map_odom_tracker.inverse() * T_map_camera;
  if (jumped && T_odom_camera_last_) {
    // Chosen so that odom -> camera equals the last published one.
    T_trackerodom_odom_ = T_trackerodom_camera * T_odom_camera_last_->inverse();
  }
  T_odom_camera_last_ = T_trackerodom_odom_.inverse() * T_trackerodom_camera;
  return T_map_odom_tracker * T_trackerodom_odom_;
}

void OdomFrame::reset() {
  T_trackerodom_odom_.setIdentity();
  T_odom_camera_last_.reset();
}

}  // namespace dypho::tracking
