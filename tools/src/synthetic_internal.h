#pragma once
/// \file synthetic_internal.h
/// Private building blocks of SyntheticScene: textures, geometry, camera and people motion.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "dypho/tools/synthetic_scene.h"

namespace dypho::tools::synth_detail {

/// Size of one texel of the room/furniture textures [m].
constexpr double kTexelM = 0.003;

/// A colour texture on a planar patch with a mip pyramid; coordinates in metres.
class Texture {
 public:
  Texture() = default;
  /// `bgr` CV_8UC3; `texel_m` = size of one texel of level 0 [m].
  Texture(const cv::Mat& bgr, double texel_m);
  /// Albedo in [0, 1] (B, G, R) at (u_m, v_m) (u right, v down, origin top-left; clamped to the
  /// patch), trilinear over the mip level that matches `footprint_m` (size of one pixel on the
  /// surface [m]).
  cv::Vec3f sample(double u_m, double v_m, double footprint_m) const;
  bool empty() const { return levels_.empty(); }

 private:
  std::vector<cv::Mat> levels_;  // CV_8UC3, level k has texel texel_m * 2^k
  double texel_m_ = kTexelM;
};

/// Generates a wall-like texture of `width_m` x `height_m`: a base colour with low-frequency
/// variation and plaster noise plus posters (checkerboards, collages, blobs, text, scribbles).
/// `poster_density` = posters per square metre. Deterministic in `rng`.
cv::Mat makeWallTexture(double width_m, double height_m, double poster_density, cv::RNG& rng);
/// Wooden planks with a rug and stains.
cv::Mat makeFloorTexture(double width_m, double height_m, cv::RNG& rng);
/// Ceiling panels with lamps and stains.
cv::Mat makeCeilingTexture(double width_m, double height_m, cv::RNG& rng);
/// Clothing of a person unrolled around the body: width = circumference, height = 1.7 m, rows
/// from the head (top) to the shoes (bottom). Texel kTexelM * 2.
cv::Mat makeClothingTexture(double circumference_m, cv::RNG& rng);

/// Axis-aligned box with one texture per face (order -x, +x, -y, +y, -z, +z).
struct TexturedBox {
  Eigen::Vector3d lo;  ///< min corner [m]
  Eigen::Vector3d hi;  ///< max corner [m]
  std::array<Texture, 6> faces;
};

/// Texture coordinates (u right, v down as seen by a viewer facing the face) of point `p` on
/// face `face` (0..5 as in TexturedBox) whose normal towards the viewer is `normal`.
Eigen::Vector2d faceUv(const TexturedBox& box, int face, const Eigen::Vector3d& normal, const Eigen::Vector3d& p);
/// Width and height [m] of the texture of face `face` (0..5) of the box [lo, hi].
Eigen::Vector2d faceSize(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int face);

/// Ground-truth camera pose at time `t_s` after the start for the options' motion.
Eigen::Isometry3d cameraPoseAt(const SynthOptions& options, double t_s);
/// Radius of the loop motion's camera circle [m]: min(1.5 m, 0.45 m/s * duration / 2pi).
double loopRadiusM(const SynthOptions& options);

/// The camera's home position on the floor plan [m] (static, rpy; centre of xyz), looking along +y.
constexpr double kCameraHomeXM = 0.0;
constexpr double kCameraHomeYM = -0.6;
/// Nearest allowed people_distance_m [m] for cameras that stay at home (static, rpy) and for those
/// that come up to 0.2 m closer (xyz, halfsphere): body axes stay >= 0.6 m from the camera.
constexpr double kMinPeopleDistanceStillM = 0.6;
constexpr double kMinPeopleDistanceMovingM = 0.8;
/// Most people the formation of the loop motion and the lanes of kTowards can show at frame 0.
constexpr int kMaxPeopleInViewLoop = 5;
constexpr int kMaxPeopleInViewTowards = 5;
/// A group of more than 4 walks in two ranks; it fits into the view at frame 0 from this distance.
constexpr double kMinGroupTwoRankInViewDistanceM = 1.0;

/// Person geometry [m]: elliptic cylinder body (semi-axes forward/side) + spherical head.
constexpr double kBodyHalfDepthM = 0.15;
constexpr double kBodyHalfWidthM = 0.25;
constexpr double kBodyBottomM = 0.02;  ///< lifted above the floor so the mask edge is unambiguous
constexpr double kBodyTopM = 1.45;
constexpr double kHeadCentreM = 1.58;
constexpr double kHeadRadiusM = 0.12;
constexpr double kPersonHeightM = kHeadCentreM + kHeadRadiusM;  // 1.70

/// Circumference of the body's elliptic cross-section [m] (width of the clothing texture).
double bodyCircumferenceM();

/// One piece of a piecewise walking path (PersonPath::legs), in the path's cycle time: a walk in a
/// straight line (smooth start and stop), standing still, or a turn on the spot.
struct PathLeg {
  double start_s = 0.0;        ///< start within the cycle [s]
  double duration_s = 1.0;     ///< > 0 [s]
  Eigen::Vector2d from{0, 0};  ///< position at the start [m]
  Eigen::Vector2d to{0, 0};    ///< position at the end [m]; == from when standing or turning
  double heading_from = 0.0;   ///< heading at the start [rad]
  double heading_to = 0.0;     ///< heading at the end [rad]; != heading_from only for a turn
  /// Walk: the speed rises from 0 to its cruise value over ramp_s (raised cosine) and falls back
  /// to 0 over the last ramp_s [s]; 2 ramp_s <= duration_s.
  double ramp_s = 0.0;
};

/// A smooth closed walking path. Either (legs empty) an ellipse x = cx + ax cos(a),
/// y = cy + ay sin(a) with a(t) = omega t + phase + wobble_amp sin(wobble_omega t + wobble_phase),
/// or a cycle of legs that repeats every cycle_s, shifted by `offset`.
struct PersonPath {
  Eigen::Vector2d centre{0, 0};  ///< [m]
  double ax = 1.0;               ///< semi-axis along x [m]
  double ay = 0.2;               ///< semi-axis along y [m]
  double omega = 0.5;            ///< angular rate [rad/s], sign = walking direction
  double phase = 0.0;            ///< [rad]
  double wobble_amp = 0.0;       ///< amplitude of the speed variation of a [rad]
  double wobble_omega = 0.0;     ///< its angular frequency [rad/s]
  double wobble_phase = 0.0;     ///< its phase [rad]

  std::vector<PathLeg> legs;     ///< one cycle, back to back from 0 to cycle_s, ends where it began
  double cycle_s = 0.0;          ///< length of the cycle [s]
  double start_s = 0.0;          ///< cycle time at t = 0 [s], in [0, cycle_s)
  Eigen::Vector2d offset{0, 0};  ///< added to every position (members of a group share the legs)
};

/// Where a person is at one time.
struct PersonState {
  Eigen::Vector2d position{0, 0};  ///< body axis on the floor [m]
  double heading = 0.0;            ///< walking direction, angle from +x [rad]
  double cos_heading = 1.0;        ///< cos(heading), cached for the ray caster
  double sin_heading = 0.0;        ///< sin(heading)
};

/// true when the options keep the people layout of earlier versions (see SynthOptions).
bool usesLegacyPeopleLayout(const SynthOptions& options);
/// people_distance_m with 0 (auto) resolved for the options' walk and people count [m].
double effectivePeopleDistanceM(const SynthOptions& options);
/// Largest people_distance_m the options' walk and people count allow [m].
double maxPeopleDistanceM(const SynthOptions& options);
/// Smallest people_distance_m the options' motion allows [m].
double minPeopleDistanceM(const SynthOptions& options);

/// Paths of `options.people` people for the options' motion and walk (see SynthOptions),
/// deterministic in `rng`.
std::vector<PersonPath> makePeoplePaths(const SynthOptions& options, cv::RNG& rng);
/// State on `path` at time `t_s`.
PersonState personStateAt(const PersonPath& path, double t_s);
/// State of a piecewise path (one with legs) at cycle time `tc_s` in [0, cycle_s).
PersonState legStateAt(const PersonPath& path, double tc_s);

/// Where a person's body appears in an image.
struct BodySpan {
  bool in_front = false;  ///< every sample point of the body is >= 0.1 m in front of the camera
  double u_lo = 0.0;      ///< leftmost image column of the body's full width [px]
  double u_hi = 0.0;      ///< rightmost image column [px]
  double v_chest = 0.0;   ///< image row of the body axis at 1.2 m height [px]
  double depth_m = 0.0;   ///< camera-frame depth of the body axis at 1.2 m [m]
  /// in_front, the whole width inside the image columns and the chest inside the image rows
  bool inside = false;
};
/// The span of a body standing at `position` seen by `camera` at `T_world_camera` (the body's
/// full width 2 kBodyHalfWidthM across the line of sight, at 0.3, 0.9 and 1.45 m height).
BodySpan bodySpan(const Eigen::Vector2d& position, const Eigen::Isometry3d& T_world_camera,
                  const CameraIntrinsics& camera);

/// Sets the start time of every unit of `paths` (people who share it: a group; indices into
/// `paths`). Without options.people_in_view_at_start at random; with it, units in turn (nearest
/// lanes first) at a time that puts all their members inside the first image, preferring times at
/// which everyone is least hidden by nearer people (at random among the nearly best); then twice
/// more, each unit again with all the others placed (synthetic_people_starts.cpp).
void chooseStarts(const SynthOptions& options, std::vector<PersonPath>& paths,
                  const std::vector<std::vector<int>>& units, cv::RNG& rng);

/// Ray against a person standing at `state`: ray o + t d (t = depth along d whose camera-frame
/// z is 1). Returns the smallest t > 1e-6 or -1; fills the outward normal and clothing (u, v) [m].
double intersectPerson(const PersonState& state, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       Eigen::Vector3d* normal, Eigen::Vector2d* uv);

/// The static content of a scene, built once by SyntheticScene: room, furniture, people's paths
/// and clothing, light.
struct SceneContent {
  TexturedBox room;  ///< faces textured for a viewer inside
  std::vector<TexturedBox> furniture;
  std::vector<PersonPath> paths;
  std::vector<Texture> clothing;                ///< one per person
  Eigen::Vector3d light_world{0.6, -0.4, 2.7};  ///< point light [m]
};

/// Everything the ray caster needs for one instant: the camera pose, where the people are, and
/// the screen-space culling rectangles of the furniture and the people.
struct RayCastView {
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  std::vector<PersonState> people;
  std::vector<cv::Rect> box_rects;     ///< one per furniture box
  std::vector<cv::Rect> person_rects;  ///< one per person
};

/// The view of `content` at time `t_s` after frame 0 for the options' camera and motion.
RayCastView makeRayCastView(const SceneContent& content, const SynthOptions& options, double t_s);

/// What the ray through one pixel hits.
struct PixelSample {
  cv::Vec3f bgr;               ///< shaded colour before rounding to 8 bits, B, G, R in [0, 255+]
  float depth_m = 0.f;         ///< depth (camera z) of the first hit [m]
  float static_depth_m = 0.f;  ///< depth of the room and furniture alone [m]
  int person = -1;             ///< index of the person hit first, -1 = none
};

/// Ray casts pixel (u, v) of `camera` in `view`.
PixelSample castPixel(const SceneContent& content, const RayCastView& view, const CameraIntrinsics& camera, int u,
                      int v);

/// The shaded colour rounded to 8 bits (saturating), as in the colour image.
inline cv::Vec3b toBgr8(const cv::Vec3f& bgr) {
  return cv::Vec3b(cv::saturate_cast<std::uint8_t>(bgr[0]), cv::saturate_cast<std::uint8_t>(bgr[1]),
                   cv::saturate_cast<std::uint8_t>(bgr[2]));
}

/// Camera effects of the colour image (synthetic_camera_effects.cpp).
/// Most ray casts one pixel of a motion-blurred image averages.
constexpr int kMaxBlurSamples = 8;
/// Number of ray casts per pixel for the motion blur of the frame at `t_s`: the largest image
/// motion [px] during [t_s - exposure_s, t_s] of the static scene (pixels of a 8 x 6 grid at their
/// frame-time depth `depth_m`) and of each person's chest, rounded up, in 1..kMaxBlurSamples; 1 when
/// exposure_s is 0.
int blurSampleCount(const SceneContent& content, const SynthOptions& options, double t_s, const cv::Mat& depth_m);
/// Time of row `row` relative to the frame's stamp [s] under the options' rolling shutter.
double rowTimeOffsetS(const SynthOptions& options, int row);
/// Renders the colour image of the frame at `t_s` with motion blur (`samples` ray casts per pixel
/// over each row's exposure) and rolling shutter into `bgr` (CV_8UC3, allocated).
void renderColourWithEffects(const SceneContent& content, const SynthOptions& options, double t_s, int samples,
                             cv::Mat& bgr);

}  // namespace dypho::tools::synth_detail
