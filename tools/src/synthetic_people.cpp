// Walking people of the synthetic scene: the paths of every walk style and the evaluation of a
// path at a time (where they start: synthetic_people_starts.cpp).
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <utility>

#include "synthetic_internal.h"

namespace dypho::tools::synth_detail {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Lane layout [m, s]. The body axes of two people stay more than one body width (0.5 m) apart by
// construction: lanes across the view are kLaneSpacingM apart, and so are the stretches of one lane
// that its people share; lanes along the view (kTowards) are kTowardsSpacingM apart sideways.
constexpr double kLaneSpacingM = 0.55;
constexpr double kLaneMaxYM = 2.15;  ///< lanes stay clear of the desk and the cabinet at +y
/// The lanes end this far beyond the edge of the first view: people turn partly in the image.
constexpr double kLaneMarginM = 0.1;
constexpr double kMaxLaneHalfLengthM = 2.5;  ///< clear of the crate and the shelf at the side walls
constexpr double kMinStretchM = 0.6;         ///< shortest stretch of a lane one person walks
constexpr double kDefaultDistanceM = 1.4;
constexpr double kDefaultTowardsDistanceM = 1.0;
/// Speed ramps at the start and the end of every walk: <= 1.4 m/s * pi / (2 * 1 s) = 2.2 m/s^2.
constexpr double kRampS = 1.0;
constexpr double kMinTurnS = 1.0, kMaxTurnS = 1.4;    ///< turning round on the spot
constexpr double kMinStandS = 1.0, kMaxStandS = 3.0;  ///< kStopAndGo: standing still
/// kStopAndGo: at most one stop per this much walk [m].
constexpr double kWalkPerStopM = 0.6;
// kTowards: lanes along the view from the back of the room to people_distance_m; the lanes beside
// the desk and the cabinet end earlier; the near ends fan out to the image edges.
constexpr double kTowardsFarYM = 2.6;  ///< 3.2 m in front of the home position
constexpr double kTowardsSideFarYM = 2.15;
constexpr double kTowardsCentreHalfWidthM = 1.2;
constexpr double kTowardsSpacingM = 0.55;
constexpr double kTowardsMaxNearXM = 2.4;
constexpr double kTowardsMaxFan = 1.35;
constexpr double kTowardsEdgeShiftM = 0.45;  ///< one or two people: the near ends move to the edges
// kGroup: up to 4 abreast (rows 0.51 m apart in depth), ranks 0.55 m apart along the lane.
constexpr int kGroupMaxAbreast = 4;
constexpr double kGroupRowSpacingM = 0.51;
constexpr double kGroupRankSpacingM = 0.55;
/// Each row is shifted this much sideways against the row in front (an echelon), so that the
/// people behind are not hidden completely.
constexpr double kGroupEchelonM = 0.3;
constexpr double kGroupJitterM = 0.02;
/// Fastest walking speed of the lane layout and the loop formation [m/s].
constexpr double kMaxWalkSpeedMS = 1.4;

/// y of the camera at frame 0 [m]: the lanes are sized to its view (halfsphere starts 0.2 m ahead
/// of the home position).
double firstCameraYM(const SynthOptions& o) { return cameraPoseAt(o, 0.0).translation().y(); }

int groupAbreast(int people) { return std::clamp(people, 1, kGroupMaxAbreast); }

/// tan of the horizontal half field of view (to the farther image edge).
double viewHalfTan(const CameraIntrinsics& c) { return std::max(c.cx + 0.5, c.width - 0.5 - c.cx) / c.fx; }

// ---------------------------------------------------------------------------------------------
// The layout of earlier versions (legacy): kept draw for draw so that the same seed gives the
// same images.

std::vector<PersonPath> legacyPaths(const SynthOptions& o, cv::RNG& rng) {
  std::vector<PersonPath> paths;
  for (int k = 0; k < o.people; ++k) {
    PersonPath p;
    const double speed_ms = rng.uniform(0.7, 1.1);  // walking speed [m/s]
    if (o.motion == SynthMotion::kLoop) {
      // A ring outside the camera circle (>= 0.5 m gap) and inside the furniture. The people
      // walk round with the camera, on the far side of the centre (the camera looks inwards),
      // so they stay in view; the wobble moves them across the image.
      const double r = loopRadiusM(o);
      const double duration_s = std::max(o.frames - 1, 1) / o.fps;
      p.centre = Eigen::Vector2d(0.0, 0.0);
      p.ax = std::min(2.55, r + 1.1 + 0.15 * k);
      p.ay = std::min(2.2, r + 0.8 + 0.15 * k);
      p.omega = 2.0 * kPi / duration_s;
      p.phase = 0.5 * kPi + 0.45 * (k - 1) + rng.uniform(-0.15, 0.15);
      p.wobble_phase = rng.uniform(0.0, 2.0 * kPi);
      p.wobble_omega = 2.0 * kPi / rng.uniform(4.0, 7.0);
      // Keep da/dt > 0 (always walking forwards, no heading flips).
      p.wobble_amp = std::min(rng.uniform(0.15, 0.3), 0.8 * p.omega / p.wobble_omega);
    } else {
      // Lanes across the view in front of the +y wall, 0.45 m apart, mostly inside the view.
      p.centre = Eigen::Vector2d(rng.uniform(-0.2, 0.2), 0.8 + 0.45 * k + rng.uniform(-0.05, 0.05));
      p.ax = rng.uniform(0.9, 1.5);
      p.ay = 0.15;
      const double mean_radius = std::sqrt(0.5 * (p.ax * p.ax + p.ay * p.ay));
      p.omega = (rng.uniform(0, 2) == 0 ? -1.0 : 1.0) * speed_ms / mean_radius;
      p.phase = rng.uniform(0.0, 2.0 * kPi);
    }
    paths.push_back(p);
  }
  return paths;
}

// ---------------------------------------------------------------------------------------------
// Piecewise paths.

/// Builds one cycle of legs: walks, stands and turns on the spot, back to back.
class CycleBuilder {
 public:
  CycleBuilder(const Eigen::Vector2d& start, double heading) : position_(start), heading_(heading) {}

  const Eigen::Vector2d& position() const { return position_; }

  /// Walks in a straight line to `to` at up to `speed_ms`, from standing to standing.
  void walk(const Eigen::Vector2d& to, double speed_ms) {
    const Eigen::Vector2d d = to - position_;
    const double length = d.norm();
    if (length < 1e-9) return;
    // Short walks are slower, so that the speed ramps keep their length (and the acceleration
    // bound).
    const double cruise_ms = std::min(speed_ms, length / kRampS);
    PathLeg& leg = add(length / cruise_ms + kRampS);
    leg.to = to;
    leg.ramp_s = kRampS;
    heading_ = std::atan2(d.y(), d.x());
    leg.heading_from = leg.heading_to = heading_;
    position_ = to;
  }

  /// Stands still (heading kept) for `duration_s`.
  void stand(double duration_s) { add(duration_s); }

  /// Turns round on the spot over `duration_s`, to the left for `direction` > 0.
  void turnRound(double duration_s, double direction) {
    PathLeg& leg = add(duration_s);
    heading_ += direction > 0 ? kPi : -kPi;
    leg.heading_to = heading_;
  }

  /// The cycle (start_s 0; it must end where it began).
  PersonPath finish() const {
    PersonPath p;
    p.legs = legs_;
    p.cycle_s = time_s_;
    return p;
  }

 private:
  PathLeg& add(double duration_s) {
    PathLeg leg;
    leg.start_s = time_s_;
    leg.duration_s = duration_s;
    leg.from = leg.to = position_;
    leg.heading_from = leg.heading_to = heading_;
    time_s_ += duration_s;
    legs_.push_back(leg);
    return legs_.back();
  }

  Eigen::Vector2d position_;
  double heading_;
  double time_s_ = 0.0;
  std::vector<PathLeg> legs_;
};

double headingOf(const Eigen::Vector2d& d) { return std::atan2(d.y(), d.x()); }

/// Back and forth between `a` and `b`, turning round on the spot at both ends.
PersonPath shuttleCycle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, cv::RNG& rng) {
  const double speed_ms = rng.uniform(0.9, 1.3);  // <= kMaxWalkSpeedMS
  CycleBuilder c(a, headingOf(b - a));
  c.walk(b, speed_ms);
  c.turnRound(rng.uniform(kMinTurnS, kMaxTurnS), rng.uniform(-1.0, 1.0));
  c.walk(a, speed_ms);
  c.turnRound(rng.uniform(kMinTurnS, kMaxTurnS), rng.uniform(-1.0, 1.0));
  return c.finish();
}

/// Walks to `to` with `stops` stops (fewer on a short way) of 1-3 s at random places on the way.
void walkWithStops(CycleBuilder& c, const Eigen::Vector2d& to, double speed_ms, int stops, cv::RNG& rng) {
  const Eigen::Vector2d from = c.position();
  const double length = (to - from).norm();
  stops = std::clamp(std::min(stops, static_cast<int>(length / kWalkPerStopM) - 1), 0, 8);
  std::vector<double> weights(stops + 1);
  for (double& w : weights) w = rng.uniform(0.5, 1.5);
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  double done = 0.0;
  for (int i = 0; i <= stops; ++i) {
    done += weights[i];
    c.walk(i == stops ? to : Eigen::Vector2d(from + (to - from) * (done / total)), speed_ms);
    if (i < stops) c.stand(rng.uniform(kMinStandS, kMaxStandS));
  }
}

/// kStopAndGo between `a` and `b`: three round trips with 0-2 stops on each way (at least one on
/// the first way when it is long enough) and, at random, a stand before turning round.
PersonPath stopAndGoCycle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, cv::RNG& rng) {
  const double speed_ms = rng.uniform(0.8, 1.3);
  CycleBuilder c(a, headingOf(b - a));
  for (int trip = 0; trip < 3; ++trip) {
    for (const Eigen::Vector2d* to : {&b, &a}) {
      const int stops = rng.uniform(0, 3);
      walkWithStops(c, *to, speed_ms, trip == 0 && to == &b ? std::max(stops, 1) : stops, rng);
      // The first end always has a stand, so that even a stretch too short for stops on the way
      // has the person standing still for a while.
      if ((trip == 0 && to == &b) || rng.uniform(0, 2) == 0) {
        c.stand(rng.uniform(kMinStandS, kMaxStandS));
      }
      c.turnRound(rng.uniform(kMinTurnS, kMaxTurnS), rng.uniform(-1.0, 1.0));
    }
  }
  return c.finish();
}

// ---------------------------------------------------------------------------------------------
// Lanes across the view (kCross, kStopAndGo).

struct Lane {
  double y = 0.0;            ///< [m]
  double half_length = 0.0;  ///< the lane runs over x in [-half_length, half_length] [m]
  int people = 0;
};

double stretchLength(const Lane& lane, int people) {
  return (2.0 * lane.half_length - (people - 1) * kLaneSpacingM) / people;
}

/// Lanes 0.55 m apart from `distance_m` in front of the home position to the back of the room,
/// each reaching kLaneMarginM beyond the first view; people go to the nearest lanes first, one
/// each, then to the lane where they get the longest stretch.
std::vector<Lane> laneLayout(const SynthOptions& o, double distance_m) {
  std::vector<Lane> lanes;
  const double tan_half = viewHalfTan(o.camera);
  const double camera_y = firstCameraYM(o);
  for (int j = 0;; ++j) {
    const double y = kCameraHomeYM + distance_m + kLaneSpacingM * j;
    if (y > kLaneMaxYM + 1e-9) break;
    lanes.push_back({y, std::min(tan_half * (y - camera_y) + kLaneMarginM, kMaxLaneHalfLengthM), 0});
  }
  if (lanes.empty()) return lanes;
  for (int k = 0; k < o.people; ++k) {
    std::size_t best = 0;
    if (static_cast<std::size_t>(k) < lanes.size()) {
      best = static_cast<std::size_t>(k);
    } else {
      for (std::size_t j = 1; j < lanes.size(); ++j) {
        if (stretchLength(lanes[j], lanes[j].people + 1) > stretchLength(lanes[best], lanes[best].people + 1)) {
          best = j;
        }
      }
    }
    ++lanes[best].people;
  }
  return lanes;
}

/// Shortest stretch anyone walks in laneLayout(o, distance_m) [m] (0 when there is no lane).
double shortestStretchM(const SynthOptions& o, double distance_m) {
  const std::vector<Lane> lanes = laneLayout(o, distance_m);
  if (lanes.empty()) return 0.0;
  double shortest = std::numeric_limits<double>::infinity();
  for (const Lane& l : lanes) {
    if (l.people > 0) shortest = std::min(shortest, stretchLength(l, l.people));
  }
  return shortest;
}

std::vector<PersonPath> lanePaths(const SynthOptions& o, cv::RNG& rng) {
  std::vector<PersonPath> paths;
  for (const Lane& l : laneLayout(o, effectivePeopleDistanceM(o))) {
    const double length = l.people > 0 ? stretchLength(l, l.people) : 0.0;
    for (int i = 0; i < l.people; ++i) {
      const double x0 = kCameraHomeXM - l.half_length + i * (length + kLaneSpacingM);
      Eigen::Vector2d a(x0, l.y), b(x0 + length, l.y);
      if (rng.uniform(0, 2) == 0) std::swap(a, b);
      paths.push_back(o.walk == SynthWalk::kStopAndGo ? stopAndGoCycle(a, b, rng) : shuttleCycle(a, b, rng));
    }
  }
  return paths;
}

// ---------------------------------------------------------------------------------------------
// Lanes along the view (kTowards).

std::vector<PersonPath> towardsPaths(const SynthOptions& o, cv::RNG& rng) {
  const int n = o.people;
  const double near_y = kCameraHomeYM + effectivePeopleDistanceM(o);
  // Far ends side by side across the back of the room; near ends fanned out (one or two people:
  // shifted to the image edges), so that the lanes never come closer than at their far ends.
  const double max_far_x = 0.5 * (n - 1) * kTowardsSpacingM;
  const double edge_shift = n <= 2 ? kTowardsEdgeShiftM : 0.0;
  const double fan = max_far_x > 0.0 ? std::min(kTowardsMaxFan, (kTowardsMaxNearXM - edge_shift) / max_far_x) : 1.0;
  std::vector<PersonPath> paths;
  for (int k = 0; k < n; ++k) {
    const double far_x = kCameraHomeXM + (k - 0.5 * (n - 1)) * kTowardsSpacingM;
    const double side = far_x > kCameraHomeXM   ? 1.0
                        : far_x < kCameraHomeXM ? -1.0
                                                : (rng.uniform(0, 2) == 0 ? -1.0 : 1.0);
    const double near_x = kCameraHomeXM + fan * (far_x - kCameraHomeXM) + side * edge_shift;
    // All lanes are straight lines through (far_x, kTowardsFarYM) and (near_x, near_y).
    const double far_y =
        std::abs(far_x - kCameraHomeXM) <= kTowardsCentreHalfWidthM ? kTowardsFarYM : kTowardsSideFarYM;
    const double along = (kTowardsFarYM - far_y) / (kTowardsFarYM - near_y);
    Eigen::Vector2d a(far_x + (near_x - far_x) * along, far_y), b(near_x, near_y);
    if (rng.uniform(0, 2) == 0) std::swap(a, b);
    paths.push_back(shuttleCycle(a, b, rng));
  }
  return paths;
}

// ---------------------------------------------------------------------------------------------
// One group on one lane across the view (kGroup): every member follows the same legs, shifted.

std::vector<PersonPath> groupPaths(const SynthOptions& o, cv::RNG& rng) {
  const int n = o.people;
  const int abreast = groupAbreast(n);
  const int ranks = (n + abreast - 1) / abreast;
  std::vector<Eigen::Vector2d> offsets;
  double max_abs_x = 0.0;
  for (int m = 0; m < n; ++m) {
    const int row = m % abreast, rank = m / abreast;
    const double x = (rank - 0.5 * (ranks - 1)) * kGroupRankSpacingM + row * kGroupEchelonM +
                     rng.uniform(-kGroupJitterM, kGroupJitterM);
    offsets.emplace_back(x, row * kGroupRowSpacingM);
    max_abs_x = std::max(max_abs_x, std::abs(x));
  }
  const double distance_m = effectivePeopleDistanceM(o);
  const double y = kCameraHomeYM + distance_m;
  const double half = std::min(viewHalfTan(o.camera) * (y - firstCameraYM(o)) + kLaneMarginM + max_abs_x,
                               kMaxLaneHalfLengthM - max_abs_x);
  Eigen::Vector2d a(kCameraHomeXM - half, y), b(kCameraHomeXM + half, y);
  if (rng.uniform(0, 2) == 0) std::swap(a, b);
  const PersonPath leader = shuttleCycle(a, b, rng);
  std::vector<PersonPath> paths;
  for (const Eigen::Vector2d& offset : offsets) {
    paths.push_back(leader);
    paths.back().offset = offset;
  }
  return paths;
}

// ---------------------------------------------------------------------------------------------
// The loop motion: a formation on two rings that walks round with the camera.

std::vector<PersonPath> loopFormation(const SynthOptions& o, cv::RNG& rng) {
  const double r = loopRadiusM(o);
  const double duration_s = std::max(o.frames - 1, 1) / o.fps;
  // Everyone shares the angular rate and the wobble, so the formation keeps its spacing; the
  // wobble moves it across the image. Outer ring as the earlier layout's first ring, inner ring
  // 0.6 m inside (the people stay on the far side of the centre, away from the camera).
  PersonPath base;
  base.omega = 2.0 * kPi / duration_s;
  base.wobble_phase = rng.uniform(0.0, 2.0 * kPi);
  base.wobble_omega = 2.0 * kPi / rng.uniform(4.0, 7.0);
  const int outer = (o.people + 1) / 2, inner = o.people / 2;
  const double outer_ax = std::min(2.55, r + 1.1), outer_ay = std::min(2.2, r + 0.8);
  // The wobble keeps da/dt > 0 and the speed (<= da/dt max(ax, ay)) <= kMaxWalkSpeedMS; the
  // shortest loop (9 s) walks the outer ring at 1.2 m/s without it.
  const double speed_cap =
      std::max(0.0, kMaxWalkSpeedMS / std::max(outer_ax, outer_ay) - base.omega) / base.wobble_omega;
  base.wobble_amp = std::min({rng.uniform(0.15, 0.3), 0.8 * base.omega / base.wobble_omega, speed_cap});
  const double shift = rng.uniform(-0.05, 0.05);
  std::vector<PersonPath> paths;
  for (int ring = 0; ring < 2; ++ring) {
    const int count = ring == 0 ? outer : inner;
    PersonPath p = base;
    p.ax = outer_ax - 0.6 * ring;
    p.ay = outer_ay - 0.6 * ring;
    // Neighbours on a ring >= 0.62 m apart along it (the ring's speed per radian >= min(ax, ay)).
    const double step = 0.62 / std::min(p.ax, p.ay);
    for (int i = 0; i < count; ++i) {
      p.phase = 0.5 * kPi + shift + (i - 0.5 * (count - 1)) * step;
      paths.push_back(p);
    }
  }
  return paths;
}

}  // namespace

PersonState legStateAt(const PersonPath& p, double tc) {
  auto it =
      std::upper_bound(p.legs.begin(), p.legs.end(), tc, [](double t, const PathLeg& leg) { return t < leg.start_s; });
  const PathLeg& leg = *(it == p.legs.begin() ? it : std::prev(it));
  const double tau = std::clamp(tc - leg.start_s, 0.0, leg.duration_s);
  Eigen::Vector2d position = leg.from;
  double heading = leg.heading_from;
  if (leg.to != leg.from) {
    // Raised-cosine speed ramps of ramp_s at both ends, constant speed v in between.
    const double length = (leg.to - leg.from).norm();
    const double ramp = leg.ramp_s, total = leg.duration_s;
    const double v = length / (total - ramp);
    auto ramped = [&](double x) { return 0.5 * v * (x - ramp / kPi * std::sin(kPi * x / ramp)); };
    const double s = tau < ramp           ? ramped(tau)
                     : tau > total - ramp ? length - ramped(total - tau)
                                          : 0.5 * v * ramp + v * (tau - ramp);
    position = leg.from + (leg.to - leg.from) * (s / length);
  } else if (leg.heading_to != leg.heading_from) {
    heading += (leg.heading_to - leg.heading_from) * 0.5 * (1.0 - std::cos(kPi * tau / leg.duration_s));
  }
  PersonState st;
  st.position = position + p.offset;
  st.heading = heading;
  st.cos_heading = std::cos(heading);
  st.sin_heading = std::sin(heading);
  return st;
}

bool usesLegacyPeopleLayout(const SynthOptions& o) {
  return o.people <= 3 && !o.people_in_view_at_start && o.walk == SynthWalk::kCross && o.people_distance_m == 0.0;
}

double minPeopleDistanceM(const SynthOptions& o) {
  switch (o.motion) {
    case SynthMotion::kStatic:
    case SynthMotion::kRpy:
    case SynthMotion::kFastRpy:
      return kMinPeopleDistanceStillM;
    case SynthMotion::kLoop:
      return 0.0;
    default:  // xyz, halfsphere: those cameras come up to 0.2 m closer
      return kMinPeopleDistanceMovingM;
  }
}

double maxPeopleDistanceM(const SynthOptions& o) {
  const double back_m = kLaneMaxYM - kCameraHomeYM;  // 2.75
  switch (o.walk) {
    case SynthWalk::kTowards:
      return kTowardsFarYM - kCameraHomeYM - 1.0;  // >= 1 m of walking
    case SynthWalk::kGroup:
      return back_m - kGroupRowSpacingM * (groupAbreast(o.people) - 1);
    case SynthWalk::kCross:
    case SynthWalk::kStopAndGo:
      // The farthest start (on a 5 cm grid) at which everyone still gets a stretch of >= 0.6 m.
      for (int cm = static_cast<int>(std::floor(back_m * 100.0 + 1e-6)); cm >= 60; cm -= 5) {
        if (shortestStretchM(o, cm / 100.0) >= kMinStretchM) return cm / 100.0;
      }
      return kMinPeopleDistanceStillM;
  }
  return back_m;
}

double effectivePeopleDistanceM(const SynthOptions& o) {
  if (o.people_distance_m != 0.0) return o.people_distance_m;
  if (o.walk == SynthWalk::kTowards) return kDefaultTowardsDistanceM;
  // Nearer than 1.4 m where many people need more lanes, or a group more depth.
  return std::min(kDefaultDistanceM, maxPeopleDistanceM(o));
}

std::vector<PersonPath> makePeoplePaths(const SynthOptions& o, cv::RNG& rng) {
  if (usesLegacyPeopleLayout(o)) return legacyPaths(o, rng);
  if (o.people == 0) return {};
  if (o.motion == SynthMotion::kLoop) return loopFormation(o, rng);
  std::vector<PersonPath> paths;
  std::vector<std::vector<int>> units;
  switch (o.walk) {
    case SynthWalk::kCross:
    case SynthWalk::kStopAndGo:
      paths = lanePaths(o, rng);
      break;
    case SynthWalk::kTowards:
      paths = towardsPaths(o, rng);
      break;
    case SynthWalk::kGroup:
      paths = groupPaths(o, rng);
      break;
  }
  if (o.walk == SynthWalk::kGroup) {
    units.emplace_back(paths.size());
    std::iota(units.back().begin(), units.back().end(), 0);
  } else {
    for (std::size_t k = 0; k < paths.size(); ++k) units.push_back({static_cast<int>(k)});
  }
  chooseStarts(o, paths, units, rng);
  return paths;
}

PersonState personStateAt(const PersonPath& p, double t) {
  if (!p.legs.empty()) {
    double tc = std::fmod(t + p.start_s, p.cycle_s);
    if (tc < 0.0) tc += p.cycle_s;
    return legStateAt(p, tc);
  }
  const double w = p.wobble_omega * t + p.wobble_phase;
  const double a = p.omega * t + p.phase + p.wobble_amp * (std::sin(w) - std::sin(p.wobble_phase));
  const double a_dot = p.omega + p.wobble_amp * p.wobble_omega * std::cos(w);
  PersonState s;
  s.position = p.centre + Eigen::Vector2d(p.ax * std::cos(a), p.ay * std::sin(a));
  const Eigen::Vector2d v(-p.ax * std::sin(a) * a_dot, p.ay * std::cos(a) * a_dot);
  s.heading = std::atan2(v.y(), v.x());
  s.cos_heading = std::cos(s.heading);
  s.sin_heading = std::sin(s.heading);
  return s;
}

BodySpan bodySpan(const Eigen::Vector2d& position, const Eigen::Isometry3d& T_world_camera,
                  const CameraIntrinsics& camera) {
  BodySpan span;
  const Eigen::Isometry3d T_camera_world = T_world_camera.inverse();
  Eigen::Vector2d sight = position - T_world_camera.translation().head<2>();
  if (sight.norm() < 1e-9) return span;
  sight.normalize();
  const Eigen::Vector2d across(-sight.y(), sight.x());
  span.in_front = true;
  span.u_lo = std::numeric_limits<double>::infinity();
  span.u_hi = -std::numeric_limits<double>::infinity();
  for (double side : {-1.0, 1.0}) {
    for (double z : {0.3, 0.9, 1.45}) {
      const Eigen::Vector2d xy = position + side * kBodyHalfWidthM * across;
      const Eigen::Vector3d pc = T_camera_world * Eigen::Vector3d(xy.x(), xy.y(), z);
      if (pc.z() < 0.1) {
        span.in_front = false;
        continue;
      }
      const double u = camera.fx * pc.x() / pc.z() + camera.cx;
      span.u_lo = std::min(span.u_lo, u);
      span.u_hi = std::max(span.u_hi, u);
    }
  }
  const Eigen::Vector3d chest = T_camera_world * Eigen::Vector3d(position.x(), position.y(), 1.2);
  span.depth_m = chest.z();
  if (chest.z() > 1e-6) span.v_chest = camera.fy * chest.y() / chest.z() + camera.cy;
  span.inside = span.in_front && span.u_lo >= -0.5 && span.u_hi <= camera.width - 0.5 && span.v_chest >= -0.5 &&
                span.v_chest <= camera.height - 0.5;
  return span;
}

}  // namespace dypho::tools::synth_detail
