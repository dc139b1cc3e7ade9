#pragma once
/// \file motion_prior.h
/// The constant-velocity camera model of the paper (delta T in B_i's R_d(G, T_{i-1} delta T)),
/// written once and used by every stage that predicts the next camera pose: tracking (the pose
/// its matching starts from), the mask (the camera's own motion removed from the flow, and the
/// pose R_d is rendered at) and mapping (the pose it renders R_d at for the mask).
///
/// Reset rules, the same for every user (a stage never keeps a velocity across a jump):
///  - an untrusted pose (tracking lost or not initialised) forgets both poses;
///  - a discontinuous pose (relocalised, loop closed, re-initialised, map reset) becomes the new
///    last pose with no velocity, so no ego-motion is computed from two poses that straddle it;
///  - a stamp not after the last one (bag restarted, duplicate) starts over from that pose;
///  - a gap longer than `max_gap_s` between two poses is treated as a jump.
/// The model keeps the camera's frame interval (the shortest recent spacing of its stamps,
/// averaged over jitter). The last step is divided by the whole intervals it spans and repeated
/// once per whole interval to the predicted stamp: a dropped frame neither halves nor doubles a
/// prediction, before or after the gap, while stamp jitter does not scale it.

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Geometry>

#include "dypho/common/types.h"

namespace dypho {

/// A tracked camera pose as the stages exchange it (tracking -> mask, mapping).
struct PoseUpdate {
  Timestamp stamp_ns = 0;                                            ///< stamp of the frame [ns]
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();  ///< camera optical frame in world
  bool trusted = false;        ///< tracking was OK on this frame (the motion to neighbours is right)
  bool discontinuous = false;  ///< the pose jumped here (relocalised, loop closed, re-initialised, reset)
  /// Tracking restarted at this frame (its stamp went backwards): a new world begins, the maps
  /// built so far do not belong to it. Implies discontinuous.
  bool restarted = false;
  /// (Last, so that brace initialisation {stamp, pose, trusted, discontinuous} keeps its meaning.)
  /// The pose is in the map's frame. False in a re-initialised segment (after max_lost_frames,
  /// until relocalisation or a loop closure ties it to the map): motion within the segment is
  /// right, but its start is a guess; nothing may render or build the map from such a pose.
  bool anchored = true;
  /// The world moved under the earlier poses before this one (a local BA applied a few frames
  /// after its keyframe): T_world_after * T_world_before^-1, to be applied to the last pose
  /// before this one is taken, so that the step between them is the camera's motion and not the
  /// correction. Identity otherwise.
  Eigen::Isometry3d T_correction = Eigen::Isometry3d::Identity();
};

/// Constant-velocity prediction from the last two trusted, continuous poses.
class ConstantVelocityModel {
 public:
  /// `max_gap_s` [s]: two poses further apart are not used for a velocity (default 1 s).
  explicit ConstantVelocityModel(double max_gap_s = 1.0) : max_gap_ns_(secondsToTimestamp(max_gap_s)) {}

  /// Takes the pose of the newest frame (rules in the file comment).
  void observe(const PoseUpdate& update) {
    if (last_) last_ = update.T_correction * *last_;
    if (!update.trusted || !update.T_world_camera.matrix().allFinite()) {
      reset();
      return;
    }
    const bool continuous = last_ && !update.discontinuous && update.stamp_ns > last_stamp_ns_ &&
                            update.stamp_ns - last_stamp_ns_ <= max_gap_ns_;
    if (continuous) {
      step_ = last_->inverse() * update.T_world_camera;
      step_ns_ = update.stamp_ns - last_stamp_ns_;
      observeInterval(step_ns_);
    } else {
      step_.reset();
      step_ns_ = 0;
    }
    last_ = update.T_world_camera;
    last_stamp_ns_ = update.stamp_ns;
  }

  /// The last pose changed after it was observed (e.g. local BA moved the keyframe it is): keeps
  /// the velocity, replaces the pose it is applied to.
  void correctLast(const Eigen::Isometry3d& T_world_camera) {
    if (last_ && T_world_camera.matrix().allFinite()) last_ = T_world_camera;
  }

  /// Forgets everything.
  void reset() {
    last_.reset();
    step_.reset();
    last_stamp_ns_ = 0;
    step_ns_ = 0;
  }

  /// True when a velocity is known (two continuous trusted poses).
  bool hasVelocity() const { return step_.has_value(); }
  /// The last trusted pose, if any.
  const std::optional<Eigen::Isometry3d>& last() const { return last_; }
  Timestamp lastStamp() const { return last_stamp_ns_; }
  /// Time between the last two poses [ns] (0 without a velocity).
  Timestamp stepNs() const { return step_ns_; }
  /// The last observed step T_prev_last (between the last two poses), if any.
  const std::optional<Eigen::Isometry3d>& lastStep() const { return step_; }
  /// The camera's frame interval [ns]: the shortest recent stamp spacing, averaged over jitter;
  /// 0 before two continuous poses.
  Timestamp frameIntervalNs() const { return interval_ns_; }
  /// Whole frame intervals the last step spans (2 when one frame was dropped between them); 1
  /// without a velocity.
  double stepIntervals() const { return step_ ? wholeIntervals(step_ns_) : 1.0; }
  /// The camera's turn per frame interval over the last step [deg]; empty without a velocity.
  std::optional<double> turnPerIntervalDeg() const {
    if (!step_) return std::nullopt;
    return Eigen::AngleAxisd(step_->rotation()).angle() * 180.0 / M_PI / stepIntervals();
  }

  /// Motion from the last pose to the camera at `stamp_ns`, T_last_predicted = delta T. With no
  /// usable velocity (none yet, stamp not after the last, or further than max_gap_s ahead): empty.
  std::optional<Eigen::Isometry3d> motionTo(Timestamp stamp_ns) const {
    if (!step_ || step_ns_ <= 0 || stamp_ns <= last_stamp_ns_ || stamp_ns - last_stamp_ns_ > max_gap_ns_) {
      return std::nullopt;
    }
    // Whole frame intervals: camera stamps jitter by several ms (TUM: 29-39 ms at 30 Hz) while the
    // frames themselves are regular, so the step per interval is repeated once per elapsed one.
    const double s = wholeIntervals(stamp_ns - last_stamp_ns_) / stepIntervals();
    const Eigen::AngleAxisd rotation(step_->rotation());
    Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
    scaled.linear() = Eigen::AngleAxisd(rotation.angle() * s, rotation.axis()).toRotationMatrix();
    scaled.translation() = step_->translation() * s;
    return scaled;
  }

  /// Predicted T_world_camera at `stamp_ns` (T_{i-1} delta T); empty as motionTo().
  std::optional<Eigen::Isometry3d> predict(Timestamp stamp_ns) const {
    const std::optional<Eigen::Isometry3d> delta = motionTo(stamp_ns);
    if (!delta) return std::nullopt;
    return *last_ * *delta;
  }

 private:
  Timestamp max_gap_ns_;
  std::optional<Eigen::Isometry3d> last_;
  /// Whole frame intervals in `dt_ns`, at least 1.
  double wholeIntervals(Timestamp dt_ns) const {
    const double interval = static_cast<double>(interval_ns_ > 0 ? interval_ns_ : step_ns_);
    return interval > 0.0 ? std::max(1.0, std::round(static_cast<double>(dt_ns) / interval)) : 1.0;
  }
  /// A continuous step of dt_ns: a shorter spacing replaces the interval (the first step may have
  /// spanned a dropped frame), one within half an interval of it is averaged in (jitter), a
  /// longer one spans dropped frames and says nothing about it.
  void observeInterval(Timestamp dt_ns) {
    if (interval_ns_ <= 0 || 4 * dt_ns < 3 * interval_ns_) {
      interval_ns_ = dt_ns;
    } else if (2 * dt_ns < 3 * interval_ns_) {
      interval_ns_ = (7 * interval_ns_ + dt_ns) / 8;
    }
  }

  Timestamp interval_ns_ = 0;              ///< the camera's frame interval [ns]; kept over resets
  std::optional<Eigen::Isometry3d> step_;  ///< T_prev_last
  Timestamp last_stamp_ns_ = 0;
  Timestamp step_ns_ = 0;  ///< time between prev and last [ns]
};

}  // namespace dypho
