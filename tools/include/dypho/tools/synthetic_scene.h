#pragma once
/// \file synthetic_scene.h
/// A deterministic synthetic RGB-D sequence of a textured room with walking people, rendered by
/// ray casting. ROS-free (OpenCV + Eigen). Used for tests, benchmarks and demos where exact ground
/// truth (camera poses, dynamic masks, noise-free static depth) is needed.
///
/// World frame: x and y horizontal, z up [m]; the room spans x in [-3.5, 3.5], y in [-3, 3],
/// z in [0, 3] (7 x 6 x 3 m). The camera is the optical frame (x right, y down, z forward), so
/// `T_world_camera` maps camera points into the world, as everywhere in dypho.

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/common/camera.h"
#include "dypho/common/types.h"

namespace dypho::tools {

/// Camera trajectory of a synthetic sequence. Every motion is smooth (C-infinity sinusoids) and,
/// but kFastRpy, stays within about 0.5 m/s and 40 deg/s (TUM hand-held speeds).
enum class SynthMotion {
  kXyz,         ///< translation along x/y/z (amplitudes 0.3/0.2/0.2 m), fixed orientation
  kHalfsphere,  ///< camera on a 1 m radius half sphere, always looking at a point 3 m ahead
  kStatic,      ///< (almost) still camera: sub-millimetre, sub-0.01 deg jitter
  kRpy,         ///< rotation only: roll, pitch, yaw of +-15 deg about a fixed position
  kLoop,        ///< one closed horizontal circle around the room centre looking inwards;
                ///< radius min(1.5 m, 0.45 m/s * duration / 2pi); last frame == first frame
  /// fast hand-held turns like TUM fr1/rpy about the home position: yaw +-27 deg at 0.5 Hz,
  /// pitch +-20 deg at 0.4 Hz, roll +-22 deg at 0.35 Hz (peak rates 85, 50, 48 deg/s; together
  /// up to about 110 deg/s, on average about 70 deg/s), growing from rest over the first 2 s
  /// (amplitudes times 1 - exp(-(t / 1 s)^2)), plus hand tremor: a non-periodic sum of
  /// sinusoids of up to 3 mm per axis with phases drawn from the seed. The view stays on the
  /// textured walls, floor and ceiling (the +y wall and its neighbours, <= 6 m away).
  kFastRpy,
};

/// Name of a motion as accepted by parseSynthMotion ("xyz", "halfsphere", "static", "rpy", "loop",
/// "fast-rpy").
std::string synthMotionName(SynthMotion motion);

/// Parses "xyz" | "halfsphere" | "static" | "rpy" | "loop" | "fast-rpy" (case-sensitive). Throws
/// std::runtime_error listing the valid names for anything else.
SynthMotion parseSynthMotion(const std::string& name);

/// How the people of a synthetic sequence walk (SynthOptions::walk; see there for the layout).
enum class SynthWalk {
  kCross,      ///< back and forth across the view on lanes parallel to the image plane (default)
  kStopAndGo,  ///< as kCross, but each person stands still for 1-3 s at irregular intervals
               ///< (smooth speed ramps; the heading is kept while standing)
  kTowards,    ///< towards the camera and away again along its view direction, from the back of
               ///< the room (3.2 m) to people_distance_m; the near ends fan out to the image edges
  kGroup,      ///< all people side by side as one group (same velocity, small offsets) on one lane
};

/// Name of a walk as accepted by parseSynthWalk ("cross", "stop-and-go", "towards", "group").
std::string synthWalkName(SynthWalk walk);

/// Parses "cross" | "stop-and-go" | "towards" | "group" (case-sensitive). Throws
/// std::runtime_error listing the valid names for anything else.
SynthWalk parseSynthWalk(const std::string& name);

/// The default synthetic camera: 640x480, fx = fy = 525, cx = 319.5, cy = 239.5, no distortion
/// (the ROS/TUM default registered-depth camera).
CameraIntrinsics defaultSynthCamera();

/// Settings of a synthetic sequence. The same options (including the seed) always give
/// bit-identical images.
///
/// People layout. With at most 3 people, walk kCross, people_in_view_at_start false and
/// people_distance_m 0, the people walk as in earlier versions (same images for the same seed):
/// on elliptic lanes 1.4, 1.85 and 2.3 m in front of the camera's home position, or on rings
/// around the room for the loop motion. Anything else uses the lane layout: straight lanes
/// across the view, 0.55 m apart from people_distance_m on, reaching 0.1 m beyond the edge of
/// the first view (people turn round on the spot at the lane ends; a lane with several people is
/// split into stretches 0.55 m apart); lanes along the view for kTowards; one lane for kGroup;
/// and, for the loop motion, a formation on two rings that walks round with the camera. Body axes
/// then stay >= 0.5 m (one body width) apart and >= 0.6 m from the camera, walking speeds
/// <= 1.4 m/s. The lane layout does not depend on `frames` (the loop formation does, like the
/// rings).
struct SynthOptions {
  int frames = 300;                               ///< number of frames, >= 1 (loop: duration >= 9 s)
  SynthMotion motion = SynthMotion::kHalfsphere;  ///< camera trajectory
  int people = 2;                                 ///< walking people, 0..8
  /// How the people walk. The loop motion takes kCross only (its people walk round with it).
  SynthWalk walk = SynthWalk::kCross;
  /// true = every person's body (its full width; top and bottom may be cut when close) is inside
  /// the image at frame 0. The start positions are chosen for it, with as little overlap between
  /// people as the lanes allow (members of a group of 5-8 may hide each other). validate()
  /// accepts it for up to 5 people with kTowards, for a kGroup of 5-8 (two ranks) from
  /// people_distance_m 1.0 m on, for up to 5 people with the loop motion (its formation starts
  /// centred in the view), and for any number otherwise.
  bool people_in_view_at_start = false;
  /// Distance [m] in front of the camera's home position, along its view direction, of the
  /// nearest lane (kCross, kStopAndGo), of the group's front row (kGroup) or of the near turning
  /// point (kTowards). 0 = auto: 1.0 m for kTowards, else 1.4 m or, where that leaves too little
  /// room, the largest allowed distance (1.1 m for 8 people on lanes, 1.22 m for a group of 4 or
  /// more). Otherwise at least 0.6 m (static, rpy, fast-rpy) or 0.8 m (xyz, halfsphere: those
  /// cameras come up to 0.2 m closer), and at most 2.2 m (kTowards), 2.75 m less 0.51 m per row
  /// behind the first (kGroup, up to 4 abreast), or the farthest distance at which the lanes in
  /// front of the furniture give everyone >= 0.6 m of lane (kCross, kStopAndGo: 2.75 m for up to
  /// 3 people, 2.2 m for 4-5, 1.65 m for 6-7, 1.1 m for 8). Must be 0 for the loop motion. With
  /// a static camera, 6 people at 0.9 m cover about 30 % of the image on average, 8 at 0.8 m
  /// about 45 %.
  double people_distance_m = 0.0;
  std::uint32_t seed = 1;                          ///< seeds textures, people paths and depth noise
  double fps = 30.0;                               ///< frame rate [Hz], (0, 1000]
  CameraIntrinsics camera = defaultSynthCamera();  ///< pinhole camera; distortion must be zero
  /// Kinect-like depth noise: sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 [m], quantised to 1/5000 m,
  /// holes (0) in a thin band at depth discontinuities, 1 % random dropout, 0 beyond 8 m.
  /// false = exact depth of the geometry (no noise, no holes, no range limit).
  bool depth_noise = true;
  double start_stamp_s = 1600000000.0;  ///< time of frame 0 [s since the Unix epoch]
  /// Motion blur of the colour image: exposure time [s], in [0, 1/fps]; 0 (default) = none, the
  /// images of earlier versions. The colour image is the mean of N ray casts at times t - (k +
  /// 0.5) exposure_s / N, k = 0..N-1, over the exposure [t - exposure_s, t] that ends at the
  /// frame's time t (camera and people move). N = min(8, ceil(largest image motion during the
  /// exposure [px])), so each step moves about 1 px or less (more when capped: 15 ms of a
  /// 100 deg/s turn is about 14 px, so 1.7 px steps); N = 1 (image motion under 1 px) is the sharp
  /// frame-time render. Depth, masks, static depth and the ground-truth pose stay at t: a Kinect's
  /// depth is not blurred like its colour. Example: 0.015 (15 ms, indoor auto exposure).
  double exposure_s = 0.0;
  /// Rolling shutter of the colour image: readout time [s] from the first image row to the last,
  /// in [0, 1/fps]; 0 (default) = global shutter. Row r ends its exposure at
  /// t + ((r + 0.5) / rows - 0.5) rolling_shutter_s (SyntheticScene::rowTimeOffsetS): the middle
  /// row at the frame's time t, the top row earlier, the bottom row later. Depth, masks, static
  /// depth and the ground-truth pose stay at t (depth like a global shutter), so the ground truth
  /// is the pose of the middle row. Example: 0.03 (TUM's Kinect colour camera reads out in about
  /// 30 ms).
  double rolling_shutter_s = 0.0;

  /// Throws std::runtime_error naming the bad field, its value and the accepted range.
  void validate() const;
  /// One line "frames=300 motion=halfsphere people=2 walk=cross ..." for logs and README files.
  std::string toString() const;
};

/// One rendered frame with its ground truth.
struct SynthFrame {
  RgbdFrame frame;  ///< BGR CV_8UC3 colour, CV_32FC1 depth [m] (noisy if depth_noise), camera
  cv::Mat mask_gt;  ///< CV_8UC1, 255 where a person is the first surface hit, else 0
  /// CV_8UC1, k + 1 where person k (0 <= k < people) is the first surface hit, else 0
  cv::Mat person_id_gt;
  cv::Mat static_depth_m;  ///< CV_32FC1 noise-free depth [m] of the room without people
  /// camera optical frame in the world (ground truth)
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

/// Deterministic synthetic dynamic scene. Construction builds the procedural textures (about
/// 0.3-0.7 s); render() is const and thread-safe and can be called in any order.
class SyntheticScene {
 public:
  /// Validates `options` (throws std::runtime_error) and builds the scene.
  explicit SyntheticScene(const SynthOptions& options);
  ~SyntheticScene();
  SyntheticScene(SyntheticScene&&) noexcept;
  SyntheticScene& operator=(SyntheticScene&&) noexcept;

  /// options.frames.
  int numFrames() const;
  /// The options the scene was built with.
  const SynthOptions& options() const;
  /// Renders frame `index` (0 <= index < numFrames(), else std::out_of_range). Rows are ray cast
  /// in parallel (cv::parallel_for_).
  SynthFrame render(int index) const;
  /// Ground-truth camera pose of frame `index` (camera optical frame in the world).
  Eigen::Isometry3d cameraPose(int index) const;
  /// Time of frame `index` [ns]: start_stamp_s + index / fps, rounded to whole microseconds so
  /// that the "%.6f" seconds of TUM text files represent it exactly.
  Timestamp stampNs(int index) const;
  /// stampNs(index) in seconds.
  double stampSeconds(int index) const;
  /// Camera pose at `t_s` seconds after frame 0 (any t_s; frame i is at i / fps): the pose of
  /// row r of frame i under a rolling shutter is cameraPoseAtTime(i / fps + rowTimeOffsetS(r)).
  Eigen::Isometry3d cameraPoseAtTime(double t_s) const;
  /// Time [s] at which image row `row` of the colour image ends its exposure, relative to the
  /// frame's time: ((row + 0.5) / rows - 0.5) rolling_shutter_s; 0 for a global shutter.
  double rowTimeOffsetS(int row) const;

 private:
  struct Impl;
  std::unique_ptr<const Impl> impl_;
};

}  // namespace dypho::tools
