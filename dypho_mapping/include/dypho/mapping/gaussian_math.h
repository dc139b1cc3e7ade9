#pragma once
/// \file gaussian_math.h
/// Per-Gaussian math of 3D Gaussian Splatting, forward and backward, written once as inline
/// host+device templates on the scalar type (float in the renderer, double in gradient checks).
///
/// Conventions: quaternions are (w, x, y, z), not necessarily normalised (normalised here);
/// covariances are full row-major 3x3 / 2x2 matrices; the camera is a pinhole (no distortion)
/// with p_camera = R_cw * p_world + t_cw; pixel centres at integer coordinates (OpenCV).
/// Colours are RGB in [0, 1] from real spherical harmonics (the 3DGS basis, degree 0-3).

#include <cmath>

#include "dypho/mapping/gaussian_sh.h"
#include "dypho/mapping/host_device.h"

namespace dypho::mapping::gs {

/// Side of the square screen tiles that Gaussians are binned into [px].
constexpr int kTileSize = 16;
/// Pixels per tile.
constexpr int kTilePixels = kTileSize * kTileSize;
/// Highest supported spherical-harmonic degree.
constexpr int kMaxShDegree = 3;
/// Added to the diagonal of every screen covariance (anti-aliasing low-pass filter) [px^2].
constexpr double kLowPassPx2 = 0.3;
/// Gaussians closer than this to the camera plane are culled [m].
constexpr double kNearPlaneM = 0.05;
/// Upper clamp of a Gaussian's alpha (keeps 1 - alpha invertible in the backward pass).
constexpr double kMaxAlpha = 0.99;

template <typename T>
struct Mat3 {
  T m[3][3];
};

/// The camera a Gaussian is projected into.
template <typename T>
struct PinholeView {
  T fx, fy, cx, cy;   ///< undistorted pinhole intrinsics [px]
  int width, height;  ///< image size [px]
  T R_cw[3][3];       ///< rotation world -> camera
  T t_cw[3];          ///< translation world -> camera [m]
  T center_w[3];      ///< camera centre in the world [m] (= -R_cw^T t_cw)
};

/// A Gaussian after projection (what the per-pixel blending needs).
template <typename T>
struct Projected {
  T mean_u, mean_v;             ///< screen position [px]
  T conic_a, conic_b, conic_c;  ///< inverse screen covariance [[a b][b c]] [1/px^2]
  T depth_m;                    ///< camera z of the centre [m]
  T opacity;                    ///< sigmoid(opacity_logit)
  T color[3];                   ///< RGB from SH, clamped at 0
  T radius_px;                  ///< radius_sigma * sqrt(largest eigenvalue) [px]
  /// Half-width and half-height of the footprint box [px] (<= radius_px): the radius box cut to
  /// the bounding box of the ellipse outside which opacity * G < min_alpha, so no pixel outside
  /// it can pass the alpha threshold (a 1e-4 relative + 1e-3 px margin covers float rounding).
  T half_u, half_v;
};

/// Exponent of a projected Gaussian at a pixel, evaluated row by row as the tile kernels do:
/// with dx = mean_u - x and dy = mean_v - y, power = -a dx^2/2 - b dx dy - c dy^2/2 (conic a, b,
/// c). conicRowTerm is the part fixed along a pixel row; conicPower adds the rest, given b * dy.
template <typename T>
DYPHO_HOST_DEVICE inline T conicRowTerm(T c, T dy) {
  return T(-0.5) * c * dy * dy;
}
template <typename T>
DYPHO_HOST_DEVICE inline T conicPower(T a, T b_dy, T row_term, T dx) {
  return T(-0.5) * a * dx * dx - b_dy * dx + row_term;
}

/// exp() used in the per-pixel blending: std::exp for double (reference, gradient checks); for
/// float a branch-free version (range reduction to 2^n * 2^f with |f| <= 1/2, degree-6
/// polynomial, relative error < 1e-6 on [-87, 87], see test_gaussian_math) that compilers vectorise. Inputs below -87
/// return ~0.
template <typename T>
DYPHO_HOST_DEVICE inline T blendExp(T x) {
  return std::exp(x);
}
template <>
DYPHO_HOST_DEVICE inline float blendExp<float>(float x) {
  x = x < -87.f ? -87.f : x;
  x = x > 87.f ? 87.f : x;
  const float t = x * 1.44269504088896341f;          // log2(e)
  const int n = static_cast<int>(t + 128.5f) - 128;  // round to nearest (argument > 0 before truncation)
  const float f = t - static_cast<float>(n);         // [-0.5, 0.5]
  // 2^f = exp(f ln2), Taylor to degree 6 on |f ln2| <= 0.347 (truncation < 1.2e-7 relative).
  const float l = f * 0.69314718055994531f;
  float p = 1.f / 720.f;
  p = p * l + 1.f / 120.f;
  p = p * l + 1.f / 24.f;
  p = p * l + 1.f / 6.f;
  p = p * l + 0.5f;
  p = p * l + 1.f;
  p = p * l + 1.f;
  union {
    int i;
    float f;
  } bits;
  bits.i = (n + 127) << 23;
  return p * bits.f;
}

template <typename T>
DYPHO_HOST_DEVICE inline T sigmoid(T x) {
  return T(1) / (T(1) + std::exp(-x));
}

/// Rotation matrix of the normalised quaternion q = (w, x, y, z).
template <typename T>
DYPHO_HOST_DEVICE inline Mat3<T> quatToRotation(const T* q) {
  const T n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const T w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
  Mat3<T> R;
  R.m[0][0] = T(1) - T(2) * (y * y + z * z);
  R.m[0][1] = T(2) * (x * y - w * z);
  R.m[0][2] = T(2) * (x * z + w * y);
  R.m[1][0] = T(2) * (x * y + w * z);
  R.m[1][1] = T(1) - T(2) * (x * x + z * z);
  R.m[1][2] = T(2) * (y * z - w * x);
  R.m[2][0] = T(2) * (x * z - w * y);
  R.m[2][1] = T(2) * (y * z + w * x);
  R.m[2][2] = T(1) - T(2) * (x * x + y * y);
  return R;
}

/// dL/dq (through the normalisation) from dL/dR.
template <typename T>
DYPHO_HOST_DEVICE inline void quatToRotationBackward(const T* q, const Mat3<T>& G, T* dq) {
  const T n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const T w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
  const auto& g = G.m;
  T dw = T(2) * (-z * g[0][1] + y * g[0][2] + z * g[1][0] - x * g[1][2] - y * g[2][0] + x * g[2][1]);
  T dx = T(2) * (y * g[0][1] + z * g[0][2] + y * g[1][0] - T(2) * x * g[1][1] - w * g[1][2] + z * g[2][0] +
                 w * g[2][1] - T(2) * x * g[2][2]);
  T dy = T(2) * (-T(2) * y * g[0][0] + x * g[0][1] + w * g[0][2] + x * g[1][0] + z * g[1][2] - w * g[2][0] +
                 z * g[2][1] - T(2) * y * g[2][2]);
  T dz = T(2) * (-T(2) * z * g[0][0] - w * g[0][1] + x * g[0][2] + w * g[1][0] - T(2) * z * g[1][1] + y * g[1][2] +
                 x * g[2][0] + y * g[2][1]);
  const T dot = w * dw + x * dx + y * dy + z * dz;  // remove the radial part, then scale by 1/n
  dq[0] = (dw - w * dot) / n;
  dq[1] = (dx - x * dot) / n;
  dq[2] = (dy - y * dot) / n;
  dq[3] = (dz - z * dot) / n;
}

/// Sigma = (R S)(R S)^T with S = diag(s).
template <typename T>
DYPHO_HOST_DEVICE inline Mat3<T> covarianceFromRotationScale(const Mat3<T>& R, const T* s) {
  Mat3<T> C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      T acc = T(0);
      for (int k = 0; k < 3; ++k) acc += R.m[i][k] * s[k] * s[k] * R.m[j][k];
      C.m[i][j] = acc;
    }
  return C;
}

/// World covariance Sigma = (R S)(R S)^T with S = diag(exp(log_scale)).
template <typename T>
DYPHO_HOST_DEVICE inline Mat3<T> covariance3d(const T* log_scale, const T* q) {
  const Mat3<T> R = quatToRotation(q);
  const T s[3] = {std::exp(log_scale[0]), std::exp(log_scale[1]), std::exp(log_scale[2])};
  return covarianceFromRotationScale(R, s);
}

/// Backward of covariance3d with its rotation R = quatToRotation(q) and scales s = exp(log_scale)
/// already computed: dL/dlog_scale, dL/dq from a symmetric dL/dSigma.
template <typename T>
DYPHO_HOST_DEVICE inline void covariance3dBackward(const Mat3<T>& R, const T* s, const T* q, const Mat3<T>& G,
                                                   T* d_log_scale, T* dq) {
  // M = R S; dL/dM = 2 G M (G symmetric).
  Mat3<T> dM, dR;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      T acc = T(0);
      for (int k = 0; k < 3; ++k) acc += G.m[i][k] * R.m[k][j] * s[j];
      dM.m[i][j] = T(2) * acc;
    }
  for (int j = 0; j < 3; ++j) {
    T ds = T(0);
    for (int i = 0; i < 3; ++i) {
      ds += dM.m[i][j] * R.m[i][j];
      dR.m[i][j] = dM.m[i][j] * s[j];
    }
    d_log_scale[j] = ds * s[j];
  }
  quatToRotationBackward(q, dR, dq);
}

/// Backward of covariance3d: dL/dlog_scale, dL/dq from a symmetric dL/dSigma.
template <typename T>
DYPHO_HOST_DEVICE inline void covariance3dBackward(const T* log_scale, const T* q, const Mat3<T>& G, T* d_log_scale,
                                                   T* dq) {
  const Mat3<T> R = quatToRotation(q);
  const T s[3] = {std::exp(log_scale[0]), std::exp(log_scale[1]), std::exp(log_scale[2])};
  covariance3dBackward(R, s, q, G, d_log_scale, dq);
}

/// Screen-space Jacobian of the pinhole projection at p_c (with the 3DGS clamp of x/z, y/z to
/// 1.3 tan(half fov), which bounds the footprint of Gaussians far outside the view).
template <typename T>
struct ProjectionJacobian {
  T J00, J02, J11, J12;
  bool clamp_x, clamp_y;
  T lim_x, lim_y;  ///< signed clamp values of x/z, y/z when clamped
};

template <typename T>
DYPHO_HOST_DEVICE inline ProjectionJacobian<T> projectionJacobian(const PinholeView<T>& cam, const T* pc) {
  ProjectionJacobian<T> J;
  const T lim_x = T(1.3) * T(0.5) * T(cam.width) / cam.fx;
  const T lim_y = T(1.3) * T(0.5) * T(cam.height) / cam.fy;
  const T z = pc[2];
  T tx = pc[0] / z, ty = pc[1] / z;
  J.clamp_x = tx < -lim_x || tx > lim_x;
  J.clamp_y = ty < -lim_y || ty > lim_y;
  tx = tx < -lim_x ? -lim_x : (tx > lim_x ? lim_x : tx);
  ty = ty < -lim_y ? -lim_y : (ty > lim_y ? lim_y : ty);
  J.lim_x = tx;
  J.lim_y = ty;
  J.J00 = cam.fx / z;
  J.J02 = -cam.fx * tx / z;
  J.J11 = cam.fy / z;
  J.J12 = -cam.fy * ty / z;
  return J;
}

/// Cheap conservative pre-test of projectGaussian plus the rasterizer's on-screen test (no
/// covariance, no SH) for the Gaussian at world (p0, p1, p2) with log std devs log_scale0..2.
/// Returns a value >= 0 when the Gaussian may reach the image, < 0 or NaN when it cannot: behind
/// the near plane, or its screen centre farther outside the image than any footprint its largest
/// scale allows. The bound: the projected covariance has trace <= ||J||_F^2 s_max^2 +
/// 2 kLowPassPx2, and projectGaussian's eigenvalue is at most that trace + sqrt(0.1); 1 % and 1 px
/// of margin cover float rounding. Never rejects a Gaussian whose projected footprint reaches the
/// image. Scalars in, float arithmetic only, branch-free: the rasterizer evaluates it in a SIMD
/// loop over Gaussians.
template <typename T>
DYPHO_HOST_DEVICE inline T imageReachMargin(const PinholeView<T>& cam, T p0, T p1, T p2, T log_scale0, T log_scale1,
                                            T log_scale2, T radius_sigma) {
  const T pc0 = cam.R_cw[0][0] * p0 + cam.R_cw[0][1] * p1 + cam.R_cw[0][2] * p2 + cam.t_cw[0];
  const T pc1 = cam.R_cw[1][0] * p0 + cam.R_cw[1][1] * p1 + cam.R_cw[1][2] * p2 + cam.t_cw[1];
  const T pc2 = cam.R_cw[2][0] * p0 + cam.R_cw[2][1] * p1 + cam.R_cw[2][2] * p2 + cam.t_cw[2];
  const T z = pc2 > T(kNearPlaneM) ? pc2 : T(1);  // keeps the arithmetic finite for culled ones
  const T tx0 = pc0 / z, ty0 = pc1 / z;
  const T u = cam.fx * tx0 + cam.cx, v = cam.fy * ty0 + cam.cy;
  // How far the centre lies outside the image [px] (0 on screen).
  const T lo = T(-0.5), hi_u = T(cam.width) - T(0.5), hi_v = T(cam.height) - T(0.5);
  const T du = u < lo ? lo - u : (u > hi_u ? u - hi_u : T(0));
  const T dv = v < lo ? lo - v : (v > hi_v ? v - hi_v : T(0));
  // ||J||_F^2 of projectionJacobian (x/z, y/z clamped the same way).
  const T lim_x = T(1.3) * T(0.5) * T(cam.width) / cam.fx, lim_y = T(1.3) * T(0.5) * T(cam.height) / cam.fy;
  const T tx = tx0 < -lim_x ? -lim_x : (tx0 > lim_x ? lim_x : tx0);
  const T ty = ty0 < -lim_y ? -lim_y : (ty0 > lim_y ? lim_y : ty0);
  const T jn2 = (cam.fx * cam.fx * (T(1) + tx * tx) + cam.fy * cam.fy * (T(1) + ty * ty)) / (z * z);
  T ls = log_scale0 > log_scale1 ? log_scale0 : log_scale1;
  ls = ls > log_scale2 ? ls : log_scale2;
  const T s2 = blendExp(T(2) * ls);  // float: 1e-6 relative, within the 1 % margin
  const T lambda = jn2 * s2 + T(2 * kLowPassPx2) + T(0.3163);
  const T r = radius_sigma * std::sqrt(lambda) * T(1.01) + T(1);
  const T reach_u = r - du, reach_v = r - dv;
  // On screen (du = dv = 0; also a NaN centre, which the on-screen test after projectGaussian
  // rejects): reachable whatever r is.
  const T reach = du + dv == T(0) ? T(1) : (reach_u < reach_v ? reach_u : reach_v);
  return pc2 > T(kNearPlaneM) ? reach : T(-1);
}

/// imageReachMargin() >= 0.
template <typename T>
DYPHO_HOST_DEVICE inline bool mayReachImage(const PinholeView<T>& cam, T p0, T p1, T p2, T log_scale0, T log_scale1,
                                            T log_scale2, T radius_sigma) {
  return imageReachMargin(cam, p0, p1, p2, log_scale0, log_scale1, log_scale2, radius_sigma) >= T(0);
}

/// Projects one Gaussian. Returns false when it is behind the near plane, degenerate, or too
/// transparent to ever reach `min_alpha`. The footprint radius is the distance along the major
/// screen axis at which alpha falls below `min_alpha` (sqrt(2 ln(opacity / min_alpha)) standard
/// deviations), capped at `radius_sigma` standard deviations; outside it no pixel can pass the
/// alpha threshold, so the box is exact.
/// `sh` holds shCoeffCount(degree) x 3 values, coefficient-major (k0 r g b, k1 r g b, ...).
template <typename T>
DYPHO_HOST_DEVICE inline bool projectGaussian(const PinholeView<T>& cam, const T* pos, const T* log_scale,
                                              const T* quat, T opacity_logit, const T* sh, int degree, T radius_sigma,
                                              T min_alpha, Projected<T>& out) {
  T pc[3];
  for (int i = 0; i < 3; ++i)
    pc[i] = cam.R_cw[i][0] * pos[0] + cam.R_cw[i][1] * pos[1] + cam.R_cw[i][2] * pos[2] + cam.t_cw[i];
  if (!(pc[2] > T(kNearPlaneM))) return false;
  const ProjectionJacobian<T> J = projectionJacobian(cam, pc);
  // T2 = J R_cw (2x3).
  T A[2][3];
  for (int j = 0; j < 3; ++j) {
    A[0][j] = J.J00 * cam.R_cw[0][j] + J.J02 * cam.R_cw[2][j];
    A[1][j] = J.J11 * cam.R_cw[1][j] + J.J12 * cam.R_cw[2][j];
  }
  const Mat3<T> S = covariance3d(log_scale, quat);
  T AS[2][3];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) AS[i][j] = A[i][0] * S.m[0][j] + A[i][1] * S.m[1][j] + A[i][2] * S.m[2][j];
  const T a = AS[0][0] * A[0][0] + AS[0][1] * A[0][1] + AS[0][2] * A[0][2] + T(kLowPassPx2);
  const T b = AS[0][0] * A[1][0] + AS[0][1] * A[1][1] + AS[0][2] * A[1][2];
  const T c = AS[1][0] * A[1][0] + AS[1][1] * A[1][1] + AS[1][2] * A[1][2] + T(kLowPassPx2);
  const T det = a * c - b * b;
  if (!(det > T(0))) return false;
  out.conic_a = c / det;
  out.conic_b = -b / det;
  out.conic_c = a / det;
  const T mid = T(0.5) * (a + c);
  const T disc = mid * mid - det;
  const T lambda = mid + std::sqrt(disc > T(0.1) ? disc : T(0.1));
  out.opacity = sigmoid(opacity_logit);
  T extent = radius_sigma;
  T alpha_extent2 = T(-1);  // squared Mahalanobis radius where opacity * G = min_alpha (< 0: none)
  if (min_alpha > T(0)) {
    if (!(out.opacity > min_alpha)) return false;
    alpha_extent2 = T(2) * std::log(out.opacity / min_alpha);
    const T e = std::sqrt(alpha_extent2);
    extent = e < extent ? e : extent;
  }
  out.radius_px = extent * std::sqrt(lambda);
  out.half_u = out.half_v = out.radius_px;
  if (alpha_extent2 > T(0)) {
    // Bounding box of {x : x^T Sigma2^-1 x <= alpha_extent2}: half sizes sqrt(alpha_extent2 * a), (.. * c).
    const T hu = std::sqrt(alpha_extent2 * a) * T(1.0001) + T(1e-3);
    const T hv = std::sqrt(alpha_extent2 * c) * T(1.0001) + T(1e-3);
    out.half_u = hu < out.half_u ? hu : out.half_u;
    out.half_v = hv < out.half_v ? hv : out.half_v;
  }
  out.mean_u = cam.fx * pc[0] / pc[2] + cam.cx;
  out.mean_v = cam.fy * pc[1] / pc[2] + cam.cy;
  out.depth_m = pc[2];
  // Colour from SH along the viewing direction.
  T dir[3] = {pos[0] - cam.center_w[0], pos[1] - cam.center_w[1], pos[2] - cam.center_w[2]};
  const T n = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (int i = 0; i < 3; ++i) dir[i] /= n;
  T basis[16];
  shBasis(degree, dir, basis);
  for (int ch = 0; ch < 3; ++ch) {
    T v = T(0.5);
    for (int k = 0; k < shCoeffCount(degree); ++k) v += basis[k] * sh[3 * k + ch];
    out.color[ch] = v > T(0) ? v : T(0);
  }
  return true;
}

/// Screen-space gradients of one Gaussian, summed over the pixels it touched.
template <typename T>
struct ScreenGrad {
  T mean_u, mean_v;
  T conic_a, conic_b, conic_c;  ///< w.r.t. the scalars a, b, c of power = -a dx^2/2 - b dx dy - c dy^2/2
  T opacity;                    ///< w.r.t. sigmoid(logit)
  T color[3];
  T depth;
};

/// Parameter gradients of one Gaussian (and its contribution to the camera-pose gradient).
template <typename T>
struct ParamGrad {
  T pos[3], log_scale[3], quat[4], opacity_logit;
  T sh[48];
  /// d/d(rho, phi) of a left perturbation T_cw <- exp([rho, phi]) T_cw (translation first).
  T pose[6];
};

/// p_camera = R_cw p_world + t_cw.
template <typename T>
DYPHO_HOST_DEVICE inline void worldToCamera(const PinholeView<T>& cam, const T* pos, T* pc) {
  for (int i = 0; i < 3; ++i)
    pc[i] = cam.R_cw[i][0] * pos[0] + cam.R_cw[i][1] * pos[1] + cam.R_cw[i][2] * pos[2] + cam.t_cw[i];
}

/// A = J R_cw (2x3): the screen Jacobian w.r.t. the world point.
template <typename T>
DYPHO_HOST_DEVICE inline void screenJacobianWorld(const PinholeView<T>& cam, const ProjectionJacobian<T>& J,
                                                  T A[2][3]) {
  for (int j = 0; j < 3; ++j) {
    A[0][j] = J.J00 * cam.R_cw[0][j] + J.J02 * cam.R_cw[2][j];
    A[1][j] = J.J11 * cam.R_cw[1][j] + J.J12 * cam.R_cw[2][j];
  }
}

/// Backward of the conic C = (A Sigma A^T + low-pass)^-1 with Sigma = covariance3d(log_scale,
/// quat): writes dL/dlog_scale and dL/dquat to `out` and dL/dA to GA, from the screen gradient.
template <typename T>
DYPHO_HOST_DEVICE inline void screenCovarianceBackward(const T A[2][3], const T* log_scale, const T* quat,
                                                       const ScreenGrad<T>& g, ParamGrad<T>& out, T GA[2][3]) {
  const Mat3<T> Rq = quatToRotation(quat);  // once for the covariance and its backward
  const T sc[3] = {std::exp(log_scale[0]), std::exp(log_scale[1]), std::exp(log_scale[2])};
  const Mat3<T> S = covarianceFromRotationScale(Rq, sc);
  T AS[2][3];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) AS[i][j] = A[i][0] * S.m[0][j] + A[i][1] * S.m[1][j] + A[i][2] * S.m[2][j];
  const T a = AS[0][0] * A[0][0] + AS[0][1] * A[0][1] + AS[0][2] * A[0][2] + T(kLowPassPx2);
  const T b = AS[0][0] * A[1][0] + AS[0][1] * A[1][1] + AS[0][2] * A[1][2];
  const T c = AS[1][0] * A[1][0] + AS[1][1] * A[1][1] + AS[1][2] * A[1][2] + T(kLowPassPx2);
  const T det = a * c - b * b;
  const T C[2][2] = {{c / det, -b / det}, {-b / det, a / det}};
  // dL/dConic as a symmetric matrix, then dL/dSigma2 = -C G C.
  const T G[2][2] = {{g.conic_a, T(0.5) * g.conic_b}, {T(0.5) * g.conic_b, g.conic_c}};
  T CG[2][2], GS2[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) CG[i][j] = C[i][0] * G[0][j] + C[i][1] * G[1][j];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) GS2[i][j] = -(CG[i][0] * C[0][j] + CG[i][1] * C[1][j]);
  // Sigma2 = A S A^T: dL/dS = A^T GS2 A; dL/dA = 2 GS2 A S.
  Mat3<T> GS3;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      T acc = T(0);
      for (int k = 0; k < 2; ++k)
        for (int l = 0; l < 2; ++l) acc += A[k][i] * GS2[k][l] * A[l][j];
      GS3.m[i][j] = acc;
    }
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) GA[i][j] = T(2) * (GS2[i][0] * AS[0][j] + GS2[i][1] * AS[1][j]);
  covariance3dBackward(Rq, sc, quat, GS3, out.log_scale, out.quat);
}

/// Gradients of A = J R_cw's factors.
template <typename T>
struct ScreenJacobianGrad {
  T gJ00, gJ02, gJ11, gJ12;  ///< dL/dJ = GA R^T (only the four non-zero entries)
  T GW[3][3];                ///< dL/dR_cw = J^T GA
};

/// Backward of A = J R_cw from dL/dA.
template <typename T>
DYPHO_HOST_DEVICE inline ScreenJacobianGrad<T> screenJacobianBackward(const PinholeView<T>& cam,
                                                                      const ProjectionJacobian<T>& J,
                                                                      const T GA[2][3]) {
  ScreenJacobianGrad<T> out;
  out.gJ00 = T(0), out.gJ02 = T(0), out.gJ11 = T(0), out.gJ12 = T(0);
  for (int j = 0; j < 3; ++j) {
    out.gJ00 += GA[0][j] * cam.R_cw[0][j];
    out.gJ02 += GA[0][j] * cam.R_cw[2][j];
    out.gJ11 += GA[1][j] * cam.R_cw[1][j];
    out.gJ12 += GA[1][j] * cam.R_cw[2][j];
  }
  for (int j = 0; j < 3; ++j) {
    out.GW[0][j] = J.J00 * GA[0][j];
    out.GW[1][j] = J.J11 * GA[1][j];
    out.GW[2][j] = J.J02 * GA[0][j] + J.J12 * GA[1][j];
  }
  return out;
}

/// dL/dp_c (gpc) from J's gradient `gj`, the screen mean's and the depth's.
template <typename T>
DYPHO_HOST_DEVICE inline void cameraPointBackward(const PinholeView<T>& cam, const ProjectionJacobian<T>& J,
                                                  const T* pc, const ScreenJacobianGrad<T>& gj, const ScreenGrad<T>& g,
                                                  T* gpc) {
  const T z = pc[2], iz = T(1) / z, iz2 = iz * iz;
  gpc[0] = T(0), gpc[1] = T(0), gpc[2] = T(0);
  gpc[2] += -cam.fx * iz2 * gj.gJ00 - cam.fy * iz2 * gj.gJ11;
  if (J.clamp_x) {
    gpc[2] += cam.fx * J.lim_x * iz2 * gj.gJ02;
  } else {
    gpc[0] += -cam.fx * iz2 * gj.gJ02;
    gpc[2] += T(2) * cam.fx * pc[0] * iz2 * iz * gj.gJ02;
  }
  if (J.clamp_y) {
    gpc[2] += cam.fy * J.lim_y * iz2 * gj.gJ12;
  } else {
    gpc[1] += -cam.fy * iz2 * gj.gJ12;
    gpc[2] += T(2) * cam.fy * pc[1] * iz2 * iz * gj.gJ12;
  }
  gpc[0] += cam.fx * iz * g.mean_u;
  gpc[2] += -cam.fx * pc[0] * iz2 * g.mean_u;
  gpc[1] += cam.fy * iz * g.mean_v;
  gpc[2] += -cam.fy * pc[1] * iz2 * g.mean_v;
  gpc[2] += g.depth;
}

/// Backward of the SH colour (clamped at 0) along the viewing direction: writes dL/dsh to
/// out.sh and dL/dpos through the direction to gv.
template <typename T>
DYPHO_HOST_DEVICE inline void shColorBackward(const PinholeView<T>& cam, const T* pos, const T* sh, int degree,
                                              const ScreenGrad<T>& g, ParamGrad<T>& out, T* gv) {
  T v[3] = {pos[0] - cam.center_w[0], pos[1] - cam.center_w[1], pos[2] - cam.center_w[2]};
  const T n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  const T dir[3] = {v[0] / n, v[1] / n, v[2] / n};
  T basis[16];
  T dbasis[16][3];
  shBasis(degree, dir, basis);
  shBasisGrad(degree, dir, dbasis);
  const int K = shCoeffCount(degree);
  T gdir[3] = {T(0), T(0), T(0)};
  for (int ch = 0; ch < 3; ++ch) {
    T raw = T(0.5);
    for (int k = 0; k < K; ++k) raw += basis[k] * sh[3 * k + ch];
    const T gc = raw > T(0) ? g.color[ch] : T(0);
    for (int k = 0; k < K; ++k) {
      out.sh[3 * k + ch] = basis[k] * gc;
      for (int i = 0; i < 3; ++i) gdir[i] += dbasis[k][i] * sh[3 * k + ch] * gc;
    }
  }
  const T ddot = dir[0] * gdir[0] + dir[1] * gdir[1] + dir[2] * gdir[2];
  for (int i = 0; i < 3; ++i) gv[i] = (gdir[i] - dir[i] * ddot) / n;
}

/// The Gaussian's share of the camera-pose gradient (out.pose) from dL/dp_c, the direction's
/// dL/dpos and dL/dR_cw.
template <typename T>
DYPHO_HOST_DEVICE inline void poseBackward(const PinholeView<T>& cam, const T* pc, const T* gpc, const T* gv,
                                           const T GW[3][3], ParamGrad<T>& out) {
  // Pose: p_c <- p_c + rho + phi x p_c; R_cw <- (I + [phi]x) R_cw; centre <- centre - R_cw^T rho.
  for (int i = 0; i < 3; ++i)
    out.pose[i] = gpc[i] + (cam.R_cw[i][0] * gv[0] + cam.R_cw[i][1] * gv[1] + cam.R_cw[i][2] * gv[2]);
  out.pose[3] = pc[1] * gpc[2] - pc[2] * gpc[1];
  out.pose[4] = pc[2] * gpc[0] - pc[0] * gpc[2];
  out.pose[5] = pc[0] * gpc[1] - pc[1] * gpc[0];
  T B[3][3];  // GW R_cw^T
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      B[i][j] = GW[i][0] * cam.R_cw[j][0] + GW[i][1] * cam.R_cw[j][1] + GW[i][2] * cam.R_cw[j][2];
  out.pose[3] += B[2][1] - B[1][2];
  out.pose[4] += B[0][2] - B[2][0];
  out.pose[5] += B[1][0] - B[0][1];
}

/// Backward of projectGaussian: chains the screen-space gradient to the Gaussian's parameters
/// and to the camera pose.
template <typename T>
DYPHO_HOST_DEVICE inline void projectGaussianBackward(const PinholeView<T>& cam, const T* pos, const T* log_scale,
                                                      const T* quat, T opacity_logit, const T* sh, int degree,
                                                      const ScreenGrad<T>& g, ParamGrad<T>& out) {
  T pc[3];
  worldToCamera(cam, pos, pc);
  const ProjectionJacobian<T> J = projectionJacobian(cam, pc);
  T A[2][3];
  screenJacobianWorld(cam, J, A);
  T GA[2][3];
  screenCovarianceBackward(A, log_scale, quat, g, out, GA);
  const ScreenJacobianGrad<T> gj = screenJacobianBackward(cam, J, GA);
  // dL/dp_c from J, the mean and the depth.
  T gpc[3];
  cameraPointBackward(cam, J, pc, gj, g, gpc);
  // Colour: SH coefficients and the viewing direction.
  T gv[3];
  shColorBackward(cam, pos, sh, degree, g, out, gv);
  // World position.
  for (int j = 0; j < 3; ++j)
    out.pos[j] = cam.R_cw[0][j] * gpc[0] + cam.R_cw[1][j] * gpc[1] + cam.R_cw[2][j] * gpc[2] + gv[j];
  const T o = sigmoid(opacity_logit);
  out.opacity_logit = g.opacity * o * (T(1) - o);
  poseBackward(cam, pc, gpc, gv, gj.GW, out);
}

}  // namespace dypho::mapping::gs
