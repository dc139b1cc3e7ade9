// SyntheticScene: builds the textured room, furniture and people once, then ray casts frames.
#include "dypho/tools/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <opencv2/core/utility.hpp>

#include "synthetic_internal.h"

namespace dypho::tools {

using synth_detail::PersonState;
using synth_detail::Texture;
using synth_detail::TexturedBox;

namespace {

/// Kinect-like axial noise [m] at depth z [m] (Khoshelham & Elberink style quadratic model).
double kinectSigmaM(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

constexpr double kDepthQuantumM = 1.0 / 5000.0;  ///< TUM PNG depth step [m]
constexpr double kMaxRangeM = 8.0;               ///< no return beyond [m]
constexpr double kDropoutRate = 0.01;            ///< random invalid pixels (fraction)
constexpr float kAmbient = 0.45f;                ///< ambient share of the shading

/// Builds a box with `faces` textures drawn by makeWallTexture (bottom face plain).
TexturedBox makeBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double density, cv::RNG& rng) {
  TexturedBox box;
  box.lo = lo;
  box.hi = hi;
  for (int f = 0; f < 6; ++f) {
    const Eigen::Vector2d size = synth_detail::faceSize(lo, hi, f);
    box.faces[f] =
        f == 4 ? Texture(cv::Mat(8, 8, CV_8UC3, cv::Scalar(40, 40, 40)), 1.0)
               : Texture(synth_detail::makeWallTexture(size.x(), size.y(), density, rng), synth_detail::kTexelM);
  }
  return box;
}

/// Seeds one frame's noise independently of the render order.
cv::RNG frameRng(std::uint32_t seed, int index) {
  std::uint64_t s = (static_cast<std::uint64_t>(seed) << 32) ^ 0x5DEECE66DULL;
  s ^= (static_cast<std::uint64_t>(index) + 1) * 0x9E3779B97F4A7C15ULL;
  return cv::RNG(s == 0 ? 1 : s);
}

/// Adds Kinect-like noise, holes at discontinuities, dropout and the range limit to `depth`.
void applyKinectNoise(const cv::Mat& clean, cv::Mat& depth, cv::RNG& rng) {
  cv::Mat gauss(clean.size(), CV_32FC1), uni(clean.size(), CV_32FC1);
  rng.fill(gauss, cv::RNG::NORMAL, 0.0, 1.0);
  rng.fill(uni, cv::RNG::UNIFORM, 0.0, 1.0);
  depth.create(clean.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, clean.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const float* z = clean.ptr<float>(v);
      const float* up = clean.ptr<float>(std::max(v - 1, 0));
      const float* down = clean.ptr<float>(std::min(v + 1, clean.rows - 1));
      const float* g = gauss.ptr<float>(v);
      const float* r = uni.ptr<float>(v);
      float* out = depth.ptr<float>(v);
      for (int u = 0; u < clean.cols; ++u) {
        const float zc = z[u];
        // A depth jump to any 8-neighbour above max(5 cm, 4 %) makes a hole band on both sides.
        const float jump = std::max(0.05f, 0.04f * zc);
        bool edge = false;
        for (int du = -1; du <= 1 && !edge; ++du) {
          const int uu = std::clamp(u + du, 0, clean.cols - 1);
          edge = std::abs(up[uu] - zc) > jump || std::abs(z[uu] - zc) > jump || std::abs(down[uu] - zc) > jump;
        }
        if (edge || !(zc > 0.f) || zc > kMaxRangeM || r[u] < kDropoutRate) {
          out[u] = 0.f;
          continue;
        }
        const double zn = zc + g[u] * kinectSigmaM(zc);
        out[u] = static_cast<float>(std::round(zn / kDepthQuantumM) * kDepthQuantumM);
      }
    }
  });
}

}  // namespace

struct SyntheticScene::Impl {
  SynthOptions options;
  synth_detail::SceneContent content;
};

SyntheticScene::SyntheticScene(const SynthOptions& options) {
  options.validate();
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  synth_detail::SceneContent& c = impl->content;
  cv::RNG tex_rng(0x1234ABCDULL ^ (static_cast<std::uint64_t>(options.seed) * 2654435761ULL));
  c.room.lo = Eigen::Vector3d(-3.5, -3.0, 0.0);
  c.room.hi = Eigen::Vector3d(3.5, 3.0, 3.0);
  for (int f = 0; f < 6; ++f) {
    const Eigen::Vector2d size = synth_detail::faceSize(c.room.lo, c.room.hi, f);
    cv::Mat tex = f == 4   ? synth_detail::makeFloorTexture(size.x(), size.y(), tex_rng)
                  : f == 5 ? synth_detail::makeCeilingTexture(size.x(), size.y(), tex_rng)
                           : synth_detail::makeWallTexture(size.x(), size.y(), f == 3 ? 2.2 : 1.6, tex_rng);
    c.room.faces[f] = Texture(tex, synth_detail::kTexelM);
  }
  // Furniture against the walls, clear of the people's paths and of the camera.
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> boxes[] = {
      {{-3.0, 2.45, 0.0}, {-1.6, 3.0, 0.75}},  // desk at the +y wall
      {{1.7, 2.55, 0.0}, {2.6, 3.0, 1.9}},     // cabinet at the +y wall
      {{3.0, -1.2, 0.0}, {3.5, 0.4, 1.3}},     // shelf at the +x wall
      {{-3.5, -0.5, 0.0}, {-2.9, 0.6, 0.9}},   // crate at the -x wall
      {{-0.8, -3.0, 0.0}, {0.6, -2.5, 1.0}}};  // sideboard at the -y wall
  for (const auto& b : boxes) c.furniture.push_back(makeBox(b.first, b.second, 3.0, tex_rng));

  cv::RNG people_rng(0x77E1ULL ^ (static_cast<std::uint64_t>(options.seed) * 40503ULL + 1));
  c.paths = synth_detail::makePeoplePaths(options, people_rng);
  for (int k = 0; k < options.people; ++k) {
    c.clothing.emplace_back(synth_detail::makeClothingTexture(synth_detail::bodyCircumferenceM(), people_rng),
                            2 * synth_detail::kTexelM);
  }
  impl_ = std::move(impl);
}

SyntheticScene::~SyntheticScene() = default;
SyntheticScene::SyntheticScene(SyntheticScene&&) noexcept = default;
SyntheticScene& SyntheticScene::operator=(SyntheticScene&&) noexcept = default;

int SyntheticScene::numFrames() const { return impl_->options.frames; }
const SynthOptions& SyntheticScene::options() const { return impl_->options; }

Timestamp SyntheticScene::stampNs(int index) const {
  const Timestamp start_us = static_cast<Timestamp>(std::llround(impl_->options.start_stamp_s * 1e6));
  return (start_us + static_cast<Timestamp>(std::llround(index * 1e6 / impl_->options.fps))) * 1000;
}

double SyntheticScene::stampSeconds(int index) const { return timestampToSeconds(stampNs(index)); }

Eigen::Isometry3d SyntheticScene::cameraPose(int index) const {
  if (index < 0 || index >= numFrames()) {
    throw std::out_of_range("SyntheticScene: frame " + std::to_string(index) + " outside 0.." +
                            std::to_string(numFrames() - 1));
  }
  return synth_detail::cameraPoseAt(impl_->options, index / impl_->options.fps);
}

Eigen::Isometry3d SyntheticScene::cameraPoseAtTime(double t_s) const {
  return synth_detail::cameraPoseAt(impl_->options, t_s);
}

double SyntheticScene::rowTimeOffsetS(int row) const { return synth_detail::rowTimeOffsetS(impl_->options, row); }

namespace {

/// Nearest exit of a ray from inside a box: t, face and inward normal.
double roomExit(const TexturedBox& room, const Eigen::Vector3d& o, const Eigen::Vector3d& d, int* face,
                Eigen::Vector3d* n) {
  double best = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) continue;
    const bool pos = d[a] > 0;
    const double t = ((pos ? room.hi[a] : room.lo[a]) - o[a]) / d[a];
    if (t < best) {
      best = t;
      *face = 2 * a + (pos ? 1 : 0);
      *n = Eigen::Vector3d::Zero();
      (*n)[a] = pos ? -1.0 : 1.0;
    }
  }
  return best;
}

/// Slab test: entry t of a ray into a box from outside, or -1; face and outward normal.
double boxEntry(const TexturedBox& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d, int* face,
                Eigen::Vector3d* n) {
  double tmin = -std::numeric_limits<double>::infinity(), tmax = std::numeric_limits<double>::infinity();
  int axis = -1;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (o[a] < box.lo[a] || o[a] > box.hi[a]) return -1.0;
      continue;
    }
    double t1 = (box.lo[a] - o[a]) / d[a], t2 = (box.hi[a] - o[a]) / d[a];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > tmin) {
      tmin = t1;
      axis = a;
    }
    tmax = std::min(tmax, t2);
  }
  if (axis < 0 || tmin > tmax || tmin <= 1e-6) return -1.0;
  const bool from_lo = d[axis] > 0;
  *face = 2 * axis + (from_lo ? 0 : 1);
  *n = Eigen::Vector3d::Zero();
  (*n)[axis] = from_lo ? -1.0 : 1.0;
  return tmin;
}

/// Pixel rectangle containing the projection of the world box [lo, hi]; the whole image when a
/// corner is behind or very close to the camera (then no culling is safe).
cv::Rect projectedRect(const Eigen::Isometry3d& T_camera_world, const CameraIntrinsics& cam, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi) {
  const cv::Rect image(0, 0, cam.width, cam.height);
  double u0 = 1e18, v0 = 1e18, u1 = -1e18, v1 = -1e18;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d pw((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d pc = T_camera_world * pw;
    if (pc.z() < 0.05) return image;
    const double u = cam.fx * pc.x() / pc.z() + cam.cx, v = cam.fy * pc.y() / pc.z() + cam.cy;
    u0 = std::min(u0, u);
    u1 = std::max(u1, u);
    v0 = std::min(v0, v);
    v1 = std::max(v1, v);
  }
  // The convex hull of the corners contains the box's projection; 2 px margin for rounding.
  u0 = std::max(u0 - 2.0, -1.0);
  v0 = std::max(v0 - 2.0, -1.0);
  u1 = std::min(u1 + 2.0, cam.width + 1.0);
  v1 = std::min(v1 + 2.0, cam.height + 1.0);
  if (u1 <= u0 || v1 <= v0) return cv::Rect();
  const cv::Rect r(static_cast<int>(std::floor(u0)), static_cast<int>(std::floor(v0)),
                   static_cast<int>(std::ceil(u1 - u0)) + 1, static_cast<int>(std::ceil(v1 - v0)) + 1);
  return r & image;
}

}  // namespace

namespace synth_detail {

RayCastView makeRayCastView(const SceneContent& content, const SynthOptions& options, double t_s) {
  const CameraIntrinsics& cam = options.camera;
  RayCastView view;
  view.T_world_camera = cameraPoseAt(options, t_s);
  for (const auto& p : content.paths) view.people.push_back(personStateAt(p, t_s));
  // Screen-space culling rectangles of the furniture and the people.
  const Eigen::Isometry3d T_camera_world = view.T_world_camera.inverse();
  for (const auto& box : content.furniture)
    view.box_rects.push_back(projectedRect(T_camera_world, cam, box.lo, box.hi));
  for (const auto& p : view.people) {
    const double r = kBodyHalfWidthM + 0.01;
    view.person_rects.push_back(
        projectedRect(T_camera_world, cam, Eigen::Vector3d(p.position.x() - r, p.position.y() - r, 0.0),
                      Eigen::Vector3d(p.position.x() + r, p.position.y() + r, kPersonHeightM + 0.01)));
  }
  return view;
}

PixelSample castPixel(const SceneContent& s, const RayCastView& view, const CameraIntrinsics& cam, int u, int v) {
  const Eigen::Matrix3d& R = view.T_world_camera.linear();
  const Eigen::Vector3d o = view.T_world_camera.translation();
  const Eigen::Vector3d dc((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
  const Eigen::Vector3d d = R * dc;  // t along d = depth (camera z) [m]
  int face = 0;
  Eigen::Vector3d n;
  const TexturedBox* hit_box = &s.room;
  double t = roomExit(s.room, o, d, &face, &n);
  for (std::size_t k = 0; k < s.furniture.size(); ++k) {
    if (!view.box_rects[k].contains(cv::Point(u, v))) continue;
    const TexturedBox& box = s.furniture[k];
    int f;
    Eigen::Vector3d nb;
    const double tb = boxEntry(box, o, d, &f, &nb);
    if (tb > 0.0 && tb < t) {
      t = tb;
      face = f;
      n = nb;
      hit_box = &box;
    }
  }
  PixelSample out;
  out.static_depth_m = static_cast<float>(t);
  Eigen::Vector2d uv;
  for (std::size_t k = 0; k < view.people.size(); ++k) {
    if (!view.person_rects[k].contains(cv::Point(u, v))) continue;
    Eigen::Vector3d np;
    Eigen::Vector2d uvp;
    const double tp = intersectPerson(view.people[k], o, d, &np, &uvp);
    if (tp > 0.0 && tp < t) {
      t = tp;
      n = np;
      uv = uvp;
      out.person = static_cast<int>(k);
    }
  }
  const Eigen::Vector3d p = o + t * d;
  const double ray_len = t * d.norm();
  const double cos_inc = std::max(0.2, std::abs(n.dot(d)) / d.norm());
  const double footprint_m = ray_len / cam.fx / cos_inc;
  cv::Vec3f albedo;
  if (out.person >= 0) {
    albedo = s.clothing[out.person].sample(uv.x(), uv.y(), footprint_m);
  } else {
    uv = faceUv(*hit_box, face, n, p);
    albedo = hit_box->faces[face].sample(uv.x(), uv.y(), footprint_m);
  }
  const Eigen::Vector3d to_light = (s.light_world - p).normalized();
  const float lambert = static_cast<float>(std::max(0.0, n.dot(to_light)));
  const float shade = 255.f * (kAmbient + (1.f - kAmbient) * lambert);
  out.bgr = cv::Vec3f(albedo[0] * shade, albedo[1] * shade, albedo[2] * shade);
  out.depth_m = static_cast<float>(t);
  return out;
}

}  // namespace synth_detail

SynthFrame SyntheticScene::render(int index) const {
  const Impl& s = *impl_;
  const CameraIntrinsics& cam = s.options.camera;
  SynthFrame out;
  out.T_world_camera = cameraPose(index);
  out.frame.camera = cam;
  out.frame.stamp_ns = stampNs(index);
  out.frame.bgr.create(cam.height, cam.width, CV_8UC3);
  out.mask_gt.create(cam.height, cam.width, CV_8UC1);
  out.person_id_gt.create(cam.height, cam.width, CV_8UC1);
  out.static_depth_m.create(cam.height, cam.width, CV_32FC1);
  cv::Mat depth_clean(cam.height, cam.width, CV_32FC1);

  // Everything but a blurred or rolling-shutter colour image is the global render at the frame's time.
  const double t_s = index / s.options.fps;
  const synth_detail::RayCastView view = synth_detail::makeRayCastView(s.content, s.options, t_s);
  cv::parallel_for_(cv::Range(0, cam.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      auto* bgr = out.frame.bgr.ptr<cv::Vec3b>(v);
      auto* mask = out.mask_gt.ptr<std::uint8_t>(v);
      auto* person_id = out.person_id_gt.ptr<std::uint8_t>(v);
      auto* sdepth = out.static_depth_m.ptr<float>(v);
      auto* depth = depth_clean.ptr<float>(v);
      for (int u = 0; u < cam.width; ++u) {
        const synth_detail::PixelSample px = synth_detail::castPixel(s.content, view, cam, u, v);
        bgr[u] = synth_detail::toBgr8(px.bgr);
        mask[u] = px.person >= 0 ? kMaskDynamic : kMaskStatic;
        person_id[u] = static_cast<std::uint8_t>(px.person + 1);
        sdepth[u] = px.static_depth_m;
        depth[u] = px.depth_m;
      }
    }
  });
  const int blur_samples = synth_detail::blurSampleCount(s.content, s.options, t_s, depth_clean);
  if (blur_samples > 1 || s.options.rolling_shutter_s > 0.0) {
    synth_detail::renderColourWithEffects(s.content, s.options, t_s, blur_samples, out.frame.bgr);
  }

  if (s.options.depth_noise) {
    cv::RNG rng = frameRng(s.options.seed, index);
    applyKinectNoise(depth_clean, out.frame.depth_m, rng);
  } else {
    out.frame.depth_m = depth_clean;
  }
  return out;
}

}  // namespace dypho::tools
