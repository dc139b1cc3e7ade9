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
Eigen::Vector2d faceUv(const TexturedBox& box, int face, const Eigen::Vector3d& normal,
                       const Eigen::Vector3d& p);
/// Width and height [m] of the texture of face `face` (0..5) of the box [lo, hi].
Eigen::Vector2d faceSize(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int face);

/// Ground-truth camera pose at time `t_s` after the start for the options' motion.
Eigen::Isometry3d cameraPoseAt(const SynthOptions& options, double t_s);

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

/// A smooth closed walking path: an ellipse x = cx + ax cos(a), y = cy + ay sin(a) with
/// a(t) = omega t + phase + wobble_amp sin(wobble_omega t + wobble_phase).
struct PersonPath {
  Eigen::Vector2d centre{0, 0};  ///< [m]
  double ax = 1.0;               ///< semi-axis along x [m]
  double ay = 0.2;               ///< semi-axis along y [m]
  double omega = 0.5;            ///< angular rate [rad/s], sign = walking direction
  double phase = 0.0;            ///< [rad]
  double wobble_amp = 0.0;       ///< amplitude of the speed variation of a [rad]
  double wobble_omega = 0.0;     ///< its angular frequency [rad/s]
  double wobble_phase = 0.0;     ///< its phase [rad]
};

/// Where a person is at one time.
struct PersonState {
  Eigen::Vector2d position{0, 0};  ///< body axis on the floor [m]
  double heading = 0.0;            ///< walking direction, angle from +x [rad]
  double cos_heading = 1.0;        ///< cos(heading), cached for the ray caster
  double sin_heading = 0.0;        ///< sin(heading)
};

/// Paths of `options.people` people for the options' motion (lanes across the view, or a ring
/// around the loop), deterministic in `rng`.
std::vector<PersonPath> makePeoplePaths(const SynthOptions& options, cv::RNG& rng);
/// State on `path` at time `t_s`.
PersonState personStateAt(const PersonPath& path, double t_s);

/// Ray against a person standing at `state`: ray o + t d (t = depth along d whose camera-frame
/// z is 1). Returns the smallest t > 1e-6 or -1; fills the outward normal and clothing (u, v) [m].
double intersectPerson(const PersonState& state, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       Eigen::Vector3d* normal, Eigen::Vector2d* uv);

}  // namespace dypho::tools::synth_detail
