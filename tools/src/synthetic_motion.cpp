// Camera trajectories of the synthetic scene, plus the option helpers.
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "synthetic_internal.h"

namespace dypho::tools {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
/// Loop motion turns 360 deg over the sequence; this caps its rate [deg/s].
constexpr double kMaxLoopRateDegS = 40.0;
/// Loop radius cap from the speed bound [m/s] (TUM hand-held speeds are up to about 0.5 m/s).
constexpr double kLoopSpeedMS = 0.45;
}  // namespace

std::string synthMotionName(SynthMotion motion) {
  switch (motion) {
    case SynthMotion::kXyz:
      return "xyz";
    case SynthMotion::kHalfsphere:
      return "halfsphere";
    case SynthMotion::kStatic:
      return "static";
    case SynthMotion::kRpy:
      return "rpy";
    case SynthMotion::kLoop:
      return "loop";
    case SynthMotion::kFastRpy:
      return "fast-rpy";
  }
  return "unknown";
}

SynthMotion parseSynthMotion(const std::string& name) {
  for (SynthMotion m : {SynthMotion::kXyz, SynthMotion::kHalfsphere, SynthMotion::kStatic, SynthMotion::kRpy,
                        SynthMotion::kLoop, SynthMotion::kFastRpy}) {
    if (synthMotionName(m) == name) return m;
  }
  throw std::runtime_error("unknown synthetic motion '" + name +
                           "'; valid names: xyz, halfsphere, static, rpy, loop, fast-rpy");
}

std::string synthWalkName(SynthWalk walk) {
  switch (walk) {
    case SynthWalk::kCross:
      return "cross";
    case SynthWalk::kStopAndGo:
      return "stop-and-go";
    case SynthWalk::kTowards:
      return "towards";
    case SynthWalk::kGroup:
      return "group";
  }
  return "unknown";
}

SynthWalk parseSynthWalk(const std::string& name) {
  for (SynthWalk w : {SynthWalk::kCross, SynthWalk::kStopAndGo, SynthWalk::kTowards, SynthWalk::kGroup}) {
    if (synthWalkName(w) == name) return w;
  }
  throw std::runtime_error("unknown walk '" + name + "'; valid names: cross, stop-and-go, towards, group");
}

CameraIntrinsics defaultSynthCamera() {
  CameraIntrinsics c;
  c.fx = c.fy = 525.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  return c;
}

namespace {

std::string numberText(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

/// Checks the people fields of `o` (its people count is checked by the caller).
void validatePeople(const SynthOptions& o) {
  auto fail = [](const std::string& what) { throw std::runtime_error("SynthOptions: " + what); };
  const std::string n_people = std::to_string(o.people);
  const std::string distance = "people_distance_m = " + numberText(o.people_distance_m);
  if (!std::isfinite(o.people_distance_m) || o.people_distance_m < 0.0) {
    fail(distance + " must be 0 (auto) or a distance in metres");
  }
  if (o.motion == SynthMotion::kLoop) {
    if (o.walk != SynthWalk::kCross) {
      fail("walk = " + synthWalkName(o.walk) +
           " needs a camera that stays near its home position "
           "(motion static, xyz, rpy or halfsphere); with the loop motion the people walk round "
           "with the camera (walk cross)");
    }
    if (o.people_distance_m != 0.0) {
      fail(distance +
           " must be 0 (auto) for the loop motion: its people walk on rings around the "
           "room centre");
    }
    if (o.people_in_view_at_start && o.people > synth_detail::kMaxPeopleInViewLoop) {
      fail("people_in_view_at_start: at most " + std::to_string(synth_detail::kMaxPeopleInViewLoop) +
           " people fit into the first view of the loop motion (people = " + n_people + ")");
    }
    return;
  }
  if (o.people_distance_m != 0.0) {
    const double lo = synth_detail::minPeopleDistanceM(o);
    const double hi = synth_detail::maxPeopleDistanceM(o);
    if (o.people_distance_m < lo || o.people_distance_m > hi) {
      fail(distance + " must be 0 (auto) or in [" + numberText(lo) + ", " + numberText(hi) + "] m for motion " +
           synthMotionName(o.motion) + ", walk " + synthWalkName(o.walk) + " and " + n_people +
           " people (nearer brings people within 0.6 m of the camera; "
           "farther leaves too little room before the furniture at the back of the room for the "
           "lanes, with >= 0.6 m of lane for everyone)");
    }
  }
  if (o.people_in_view_at_start && o.walk == SynthWalk::kTowards && o.people > synth_detail::kMaxPeopleInViewTowards) {
    fail("people_in_view_at_start: at most " + std::to_string(synth_detail::kMaxPeopleInViewTowards) +
         " lanes of walk towards fit side by side into the view (people = " + n_people + ")");
  }
  const double distance_m = synth_detail::effectivePeopleDistanceM(o);
  const double group_min_m = synth_detail::kMinGroupTwoRankInViewDistanceM;
  if (o.people_in_view_at_start && o.walk == SynthWalk::kGroup && o.people > 4 && distance_m < group_min_m) {
    fail("people_in_view_at_start: a group of " + n_people +
         " walks in two ranks and fits into "
         "the view at frame 0 from people_distance_m = " +
         numberText(group_min_m) + " m on (got " + numberText(distance_m) + ")");
  }
}

/// Checks exposure_s and rolling_shutter_s: both within one frame period.
void validateCameraEffects(const SynthOptions& o) {
  const double period_s = 1.0 / o.fps;
  for (const auto& [name, value] : {std::pair<const char*, double>{"exposure_s", o.exposure_s},
                                    std::pair<const char*, double>{"rolling_shutter_s", o.rolling_shutter_s}}) {
    if (!std::isfinite(value) || value < 0.0 || value > period_s) {
      throw std::runtime_error(std::string("SynthOptions: ") + name + " = " + numberText(value) +
                               " must be in [0, 1/fps = " + numberText(period_s) +
                               "] s (0 = off; it cannot last longer than a frame)");
    }
  }
}

}  // namespace

void SynthOptions::validate() const {
  auto fail = [](const std::string& what) { throw std::runtime_error("SynthOptions: " + what); };
  if (frames < 1) fail("frames = " + std::to_string(frames) + " must be >= 1");
  if (people < 0 || people > 8) fail("people = " + std::to_string(people) + " must be in 0..8");
  if (!(fps > 0.0 && fps <= 1000.0)) fail("fps = " + std::to_string(fps) + " must be in (0, 1000]");
  if (!std::isfinite(start_stamp_s) || start_stamp_s < 0.0) {
    fail("start_stamp_s must be finite and >= 0 (seconds since the Unix epoch)");
  }
  if (!camera.valid() || camera.width > 4096 || camera.height > 4096) {
    fail("camera must have fx, fy > 0 and 1..4096 x 1..4096 pixels (got " + std::to_string(camera.width) + "x" +
         std::to_string(camera.height) + ")");
  }
  if (camera.distorted()) fail("camera distortion must be zero: the renderer draws a pinhole image");
  validateCameraEffects(*this);
  if (motion == SynthMotion::kLoop) {
    const double duration_s = (frames - 1) / fps;
    const double rate = 360.0 / std::max(duration_s, 1e-9);
    if (rate > kMaxLoopRateDegS) {
      const int min_frames = static_cast<int>(std::ceil(360.0 / kMaxLoopRateDegS * fps)) + 1;
      std::ostringstream ss;
      ss << "loop motion turns 360 deg over the sequence: " << frames << " frames at " << fps << " fps turn " << rate
         << " deg/s > " << kMaxLoopRateDegS << " deg/s; use at least " << min_frames << " frames";
      fail(ss.str());
    }
  }
  validatePeople(*this);
}

std::string SynthOptions::toString() const {
  std::ostringstream ss;
  ss << "frames=" << frames << " motion=" << synthMotionName(motion) << " people=" << people
     << " walk=" << synthWalkName(walk) << " people_in_view_at_start=" << (people_in_view_at_start ? "true" : "false")
     << " people_distance_m=" << people_distance_m << " seed=" << seed << " fps=" << fps << " camera=" << camera.width
     << "x" << camera.height << " fx=" << camera.fx << " fy=" << camera.fy << " cx=" << camera.cx << " cy=" << camera.cy
     << " depth_noise=" << (depth_noise ? "true" : "false") << " exposure_s=" << exposure_s
     << " rolling_shutter_s=" << rolling_shutter_s << " start_stamp_s=" << std::fixed << start_stamp_s;
  return ss.str();
}

namespace synth_detail {
namespace {

/// Camera rotation looking from `eye` at `target` with world z up (optical frame: x right,
/// y down, z forward).
Eigen::Matrix3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

Eigen::Isometry3d makePose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

double wave(double amp, double freq_hz, double phase, double t) {
  return amp * std::sin(2.0 * kPi * freq_hz * t + phase);
}

/// Phase number `k` in [0, 2pi) of the hand tremor for `seed` (splitmix64 of seed and k).
double tremorPhase(std::uint32_t seed, int k) {
  std::uint64_t z = ((static_cast<std::uint64_t>(seed) << 8) | static_cast<std::uint64_t>(k)) + 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return 2.0 * kPi * static_cast<double>(z >> 11) / 9007199254740992.0;  // 53 bits -> [0, 1)
}

/// Hand tremor [m]: per axis three sinusoids of 1.5, 1.0 and 0.5 mm at sqrt(2), sqrt(7) and
/// sqrt(23) Hz times sqrt(1 + 0.2 axis) (irrational ratios: never periodic), phases from the seed.
/// Peak speed about 6 cm/s per axis; peak acceleration about 1.5 m/s^2 (measured over 20 s).
Eigen::Vector3d handTremor(std::uint32_t seed, double t) {
  constexpr double kAmpM[3] = {1.5e-3, 1.0e-3, 0.5e-3};
  const double freq_hz[3] = {std::sqrt(2.0), std::sqrt(7.0), std::sqrt(23.0)};
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3; ++a) {
    for (int j = 0; j < 3; ++j) {
      d[a] += wave(kAmpM[j], freq_hz[j] * std::sqrt(1.0 + 0.2 * a), tremorPhase(seed, 3 * a + j), t);
    }
  }
  return d;
}

/// Amplitude envelope of the fast turns: 1 - exp(-(t / 1 s)^2), C-infinity, at rest at t = 0 and
/// above 0.98 from t = 2 s on (negative times mirror positive ones).
double fastRpyEnvelope(double t) { return 1.0 - std::exp(-t * t); }

const Eigen::Vector3d kEye0(kCameraHomeXM, kCameraHomeYM, 1.45);  // home position [m]
const Eigen::Vector3d kTarget0(0.0, 3.0, 1.25);                   // a point on the +y wall [m]
const Eigen::Vector3d kRoomCentre(0.0, 0.0, 1.45);

}  // namespace

double loopRadiusM(const SynthOptions& o) {
  const double duration_s = std::max(o.frames - 1, 1) / o.fps;
  return std::min(1.5, kLoopSpeedMS * duration_s / (2.0 * kPi));
}

Eigen::Isometry3d cameraPoseAt(const SynthOptions& o, double t) {
  switch (o.motion) {
    case SynthMotion::kXyz: {
      // Peak speeds 0.28, 0.15, 0.23 m/s per axis (|v| <= 0.39 m/s).
      const Eigen::Vector3d d(wave(0.3, 0.15, 0.0, t), wave(0.2, 0.12, 0.0, t), wave(0.2, 0.18, 0.0, t));
      return makePose(lookAt(kEye0, kTarget0), kEye0 + d);
    }
    case SynthMotion::kHalfsphere: {
      // Azimuth +-0.75 rad (period 14 s), elevation +-0.45 rad (10 s) on a 1 m sphere: <= 0.44 m/s.
      const Eigen::Vector3d centre(0.0, -1.4, 1.4);
      const double az = wave(0.75, 1.0 / 14.0, 0.0, t);
      const double el = wave(0.45, 1.0 / 10.0, 0.0, t);
      const Eigen::Vector3d eye =
          centre + Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el));
      return makePose(lookAt(eye, Eigen::Vector3d(0.0, 1.6, 1.2)), eye);
    }
    case SynthMotion::kStatic: {
      const Eigen::Vector3d d(wave(3e-4, 0.7, 0.0, t), wave(3e-4, 0.5, 1.0, t), wave(3e-4, 0.9, 2.0, t));
      const Eigen::Matrix3d R =
          lookAt(kEye0, kTarget0) *
          Eigen::AngleAxisd(wave(0.008 * kDeg, 0.6, 0.0, t), Eigen::Vector3d::UnitY()).toRotationMatrix();
      return makePose(R, kEye0 + d);
    }
    case SynthMotion::kRpy: {
      // +-15 deg at 0.2/0.17/0.23 Hz: peak rates 18.8/16.0/21.7 deg/s (|w| <= 33 deg/s).
      const Eigen::Matrix3d R = lookAt(kEye0, kTarget0) *
                                (Eigen::AngleAxisd(wave(15 * kDeg, 0.23, 0.0, t), Eigen::Vector3d::UnitY()) *  // yaw
                                 Eigen::AngleAxisd(wave(15 * kDeg, 0.17, 0.0, t), Eigen::Vector3d::UnitX()) *  // pitch
                                 Eigen::AngleAxisd(wave(15 * kDeg, 0.20, 0.0, t), Eigen::Vector3d::UnitZ()))   // roll
                                    .toRotationMatrix();
      return makePose(R, kEye0);
    }
    case SynthMotion::kFastRpy: {
      // Like TUM fr1/rpy: full amplitude +-27/20/22 deg at 0.50/0.40/0.35 Hz: peak rates 85/50/48
      // deg/s, together at most about 110 deg/s; starts at rest (envelope) at the home view.
      const double s = fastRpyEnvelope(t);
      const Eigen::Matrix3d R =
          lookAt(kEye0, kTarget0) *
          (Eigen::AngleAxisd(s * wave(27 * kDeg, 0.50, 0.0, t), Eigen::Vector3d::UnitY()) *  // yaw
           Eigen::AngleAxisd(s * wave(20 * kDeg, 0.40, 0.0, t), Eigen::Vector3d::UnitX()) *  // pitch
           Eigen::AngleAxisd(s * wave(22 * kDeg, 0.35, 0.0, t), Eigen::Vector3d::UnitZ()))   // roll
              .toRotationMatrix();
      return makePose(R, kEye0 + handTremor(o.seed, t));
    }
    case SynthMotion::kLoop: {
      // alpha runs 0 -> 2pi from frame 0 to the last frame, so the last pose equals the first.
      const double duration_s = std::max(o.frames - 1, 1) / o.fps;
      const double alpha = 2.0 * kPi * t / duration_s;
      const double r = loopRadiusM(o);
      const Eigen::Vector3d radial(std::sin(alpha), -std::cos(alpha), 0.0);
      const Eigen::Vector3d eye = kRoomCentre + r * radial;
      const Eigen::Vector3d target = kRoomCentre - 2.0 * radial + Eigen::Vector3d(0, 0, -0.3);
      return makePose(lookAt(eye, target), eye);
    }
  }
  return Eigen::Isometry3d::Identity();
}

}  // namespace synth_detail
}  // namespace dypho::tools
