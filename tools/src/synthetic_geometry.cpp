// Ray/primitive geometry of the synthetic scene: box face texture coordinates and people.
#include <cmath>

#include "synthetic_internal.h"

namespace dypho::tools::synth_detail {

Eigen::Vector2d faceUv(const TexturedBox& box, int face, const Eigen::Vector3d& n, const Eigen::Vector3d& p) {
  const int axis = face / 2;
  if (axis == 2) {  // floor-like (normal up) or ceiling-like (normal down)
    return {p.x() - box.lo.x(), n.z() > 0 ? box.hi.y() - p.y() : p.y() - box.lo.y()};
  }
  // Viewer faces -n with z up, so "right" is z x n = (-n.y, n.x, 0).
  const Eigen::Vector2d right(-n.y(), n.x());
  double u = 0.0;
  for (int a = 0; a < 2; ++a) {
    if (right[a] > 0.5) u = p[a] - box.lo[a];
    if (right[a] < -0.5) u = box.hi[a] - p[a];
  }
  return {u, box.hi.z() - p.z()};
}

Eigen::Vector2d faceSize(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int face) {
  const Eigen::Vector3d e = hi - lo;
  switch (face / 2) {
    case 0:
      return {e.y(), e.z()};
    case 1:
      return {e.x(), e.z()};
    default:
      return {e.x(), e.y()};
  }
}

double bodyCircumferenceM() {
  constexpr double kPi = 3.14159265358979323846;
  const double a = kBodyHalfDepthM, b = kBodyHalfWidthM;  // Ramanujan's approximation
  return kPi * (3.0 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b)));
}

double intersectPerson(const PersonState& s, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       Eigen::Vector3d* normal, Eigen::Vector2d* uv) {
  constexpr double kEps = 1e-6;
  constexpr double kPi = 3.14159265358979323846;
  const double c = s.cos_heading, sn = s.sin_heading;
  // Person-local frame: x forward (walking direction), y left, z up; origin on the floor.
  const double ox = o.x() - s.position.x(), oy = o.y() - s.position.y();
  const double lox = c * ox + sn * oy, loy = -sn * ox + c * oy;
  const double ldx = c * d.x() + sn * d.y(), ldy = -sn * d.x() + c * d.y();

  double best = -1.0;
  Eigen::Vector3d n_local;
  double best_z = 0.0, best_x = 0.0, best_y = 0.0;  // hit in the local frame (x, y scaled)
  auto consider = [&](double t, const Eigen::Vector3d& nl, double z, double x, double y) {
    if (t > kEps && (best < 0.0 || t < best)) {
      best = t;
      n_local = nl;
      best_z = z;
      best_x = x;
      best_y = y;
    }
  };
  // Elliptic cylinder (x/a)^2 + (y/b)^2 = 1 between bottom and top.
  const double a = kBodyHalfDepthM, b = kBodyHalfWidthM;
  const double ex = lox / a, ey = loy / b, fx = ldx / a, fy = ldy / b;
  const double A = fx * fx + fy * fy, B = 2.0 * (ex * fx + ey * fy), C = ex * ex + ey * ey - 1.0;
  const double disc = B * B - 4.0 * A * C;
  if (A > 0.0 && disc >= 0.0) {
    const double sq = std::sqrt(disc);
    for (double t : {(-B - sq) / (2.0 * A), (-B + sq) / (2.0 * A)}) {
      const double z = o.z() + t * d.z();
      if (t > kEps && z >= kBodyBottomM && z <= kBodyTopM) {
        const double x = lox + t * ldx, y = loy + t * ldy;
        consider(t, Eigen::Vector3d(x / (a * a), y / (b * b), 0.0), z, x / a, y / b);
        break;
      }
    }
  }
  // Caps (top visible from above, bottom for completeness).
  if (std::abs(d.z()) > 1e-12) {
    for (double zc : {kBodyTopM, kBodyBottomM}) {
      const double t = (zc - o.z()) / d.z();
      const double x = lox + t * ldx, y = loy + t * ldy;
      if ((x / a) * (x / a) + (y / b) * (y / b) <= 1.0) {
        consider(t, Eigen::Vector3d(0, 0, zc == kBodyTopM ? 1.0 : -1.0), zc, x / a, y / b);
      }
    }
  }
  // Head sphere.
  {
    const Eigen::Vector3d oc(lox, loy, o.z() - kHeadCentreM);
    const Eigen::Vector3d dl(ldx, ldy, d.z());
    const double hb = oc.dot(dl), hc = oc.squaredNorm() - kHeadRadiusM * kHeadRadiusM;
    const double hd = hb * hb - dl.squaredNorm() * hc;
    if (hd >= 0.0) {
      const double t = (-hb - std::sqrt(hd)) / dl.squaredNorm();
      const Eigen::Vector3d q = oc + t * dl;
      consider(t, q, o.z() + t * d.z(), q.x(), q.y());
    }
  }
  if (best < 0.0) return -1.0;
  if (normal) {
    const Eigen::Vector3d nw(c * n_local.x() - sn * n_local.y(), sn * n_local.x() + c * n_local.y(), n_local.z());
    *normal = nw.normalized();
  }
  if (uv) {
    // theta = 0 at the back of the person -> centre of the unrolled clothing texture.
    const double best_theta = std::atan2(best_y, -best_x);
    *uv = Eigen::Vector2d((best_theta + kPi) / (2.0 * kPi) * bodyCircumferenceM(), kPersonHeightM - best_z);
  }
  return best;
}

}  // namespace dypho::tools::synth_detail
