#pragma once
/// \file gaussian_sh.h
/// Real spherical harmonics of degree 0-3 (the 3DGS basis and sign convention), their
/// derivatives and their rotation, as inline host+device templates. Part of the per-Gaussian math (gaussian_math.h).

#include "dypho/mapping/host_device.h"

namespace dypho::mapping::gs {

/// The SH band-0 constant 1 / (2 sqrt(pi)): a DC coefficient dc renders as 0.5 + kShC0 * dc.
constexpr double kShC0 = 0.28209479177387814;

/// Coefficients per colour channel for an SH degree.
DYPHO_HOST_DEVICE constexpr int shCoeffCount(int degree) { return (degree + 1) * (degree + 1); }

/// Real SH basis (3DGS constants and sign convention) of the unit direction d, `count` values.
template <typename T>
DYPHO_HOST_DEVICE inline void shBasis(int degree, const T* d, T* b) {
  const T x = d[0], y = d[1], z = d[2];
  b[0] = T(kShC0);
  if (degree < 1) return;
  const T C1 = T(0.4886025119029199);
  b[1] = -C1 * y;
  b[2] = C1 * z;
  b[3] = -C1 * x;
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  b[4] = T(1.0925484305920792) * x * y;
  b[5] = T(-1.0925484305920792) * y * z;
  b[6] = T(0.31539156525252005) * (T(2) * zz - xx - yy);
  b[7] = T(-1.0925484305920792) * x * z;
  b[8] = T(0.5462742152960396) * (xx - yy);
  if (degree < 3) return;
  b[9] = T(-0.5900435899266435) * y * (T(3) * xx - yy);
  b[10] = T(2.890611442640554) * x * y * z;
  b[11] = T(-0.4570457994644658) * y * (T(4) * zz - xx - yy);
  b[12] = T(0.3731763325901154) * z * (T(2) * zz - T(3) * xx - T(3) * yy);
  b[13] = T(-0.4570457994644658) * x * (T(4) * zz - xx - yy);
  b[14] = T(1.445305721320277) * z * (xx - yy);
  b[15] = T(-0.5900435899266435) * x * (xx - T(3) * yy);
}

/// Derivatives of the SH basis w.r.t. the (unnormalised-agnostic) direction components:
/// db[k][0..2] = d b_k / d(x, y, z).
template <typename T>
DYPHO_HOST_DEVICE inline void shBasisGrad(int degree, const T* d, T (*db)[3]) {
  const T x = d[0], y = d[1], z = d[2];
  for (int k = 0; k < shCoeffCount(degree); ++k) db[k][0] = db[k][1] = db[k][2] = T(0);
  if (degree < 1) return;
  const T C1 = T(0.4886025119029199);
  db[1][1] = -C1;
  db[2][2] = C1;
  db[3][0] = -C1;
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  const T a0 = T(1.0925484305920792), a2 = T(0.31539156525252005), a4 = T(0.5462742152960396);
  db[4][0] = a0 * y;
  db[4][1] = a0 * x;
  db[5][1] = -a0 * z;
  db[5][2] = -a0 * y;
  db[6][0] = -T(2) * a2 * x;
  db[6][1] = -T(2) * a2 * y;
  db[6][2] = T(4) * a2 * z;
  db[7][0] = -a0 * z;
  db[7][2] = -a0 * x;
  db[8][0] = T(2) * a4 * x;
  db[8][1] = -T(2) * a4 * y;
  if (degree < 3) return;
  const T c0 = T(-0.5900435899266435), c1 = T(2.890611442640554), c2 = T(-0.4570457994644658),
          c3 = T(0.3731763325901154), c5 = T(1.445305721320277);
  db[9][0] = c0 * T(6) * x * y;
  db[9][1] = c0 * (T(3) * xx - T(3) * yy);
  db[10][0] = c1 * y * z;
  db[10][1] = c1 * x * z;
  db[10][2] = c1 * x * y;
  db[11][0] = c2 * (-T(2) * x * y);
  db[11][1] = c2 * (T(4) * zz - xx - T(3) * yy);
  db[11][2] = c2 * T(8) * y * z;
  db[12][0] = c3 * (-T(6) * x * z);
  db[12][1] = c3 * (-T(6) * y * z);
  db[12][2] = c3 * (T(6) * zz - T(3) * xx - T(3) * yy);
  db[13][0] = c2 * (T(4) * zz - T(3) * xx - yy);
  db[13][1] = c2 * (-T(2) * x * y);
  db[13][2] = c2 * T(8) * x * z;
  db[14][0] = c5 * T(2) * x * z;
  db[14][1] = c5 * (-T(2) * y * z);
  db[14][2] = c5 * (xx - yy);
  db[15][0] = c0 * (T(3) * xx - T(3) * yy);
  db[15][1] = c0 * (-T(6) * x * y);
}

/// Rotation of SH coefficients, one block per degree (degree 0 is invariant). For a rotation R
/// applied to a Gaussian (and its surroundings), the rotated coefficients s' = M s give the
/// rotated colour: c'(R d) = c(d) for every direction d.
template <typename T>
struct ShRotation {
  T m1[3][3];  ///< degree 1 (coefficients 1..3)
  T m2[5][5];  ///< degree 2 (coefficients 4..8)
  T m3[7][7];  ///< degree 3 (coefficients 9..15)
};

/// Builds the blocks for the rotation `R` (row-major, orthonormal) up to `degree` (blocks above it
/// are left unset). The basis is orthonormal, so M_l[k][m] = integral of b_k(d) b_m(R^T d) over the
/// sphere; the integrand is a polynomial of degree <= 6, which the 26-point Lebedev rule
/// (exact to degree 7) integrates exactly. Cost: 52 basis evaluations; build once per rotation.
template <typename T>
DYPHO_HOST_DEVICE inline void shRotation(const T R[3][3], int degree, ShRotation<T>& out) {
  for (int k = 0; k < 3; ++k)
    for (int m = 0; m < 3; ++m) out.m1[k][m] = T(0);
  for (int k = 0; k < 5; ++k)
    for (int m = 0; m < 5; ++m) out.m2[k][m] = T(0);
  for (int k = 0; k < 7; ++k)
    for (int m = 0; m < 7; ++m) out.m3[k][m] = T(0);
  if (degree < 1) return;
  const T four_pi = T(12.566370614359172);
  const T s2 = T(0.70710678118654752), s3 = T(0.57735026918962576);
  for (int j = 0; j < 26; ++j) {
    // Lebedev 26: 6 axis points (weight 1/21), 12 edge midpoints (4/105), 8 cube corners (9/280).
    T d[3];
    T w;
    if (j < 6) {
      d[0] = d[1] = d[2] = T(0);
      d[j / 2] = (j % 2) ? T(-1) : T(1);
      w = T(1) / T(21);
    } else if (j < 18) {
      const int e = j - 6, pair = e / 4;  // axis pairs (x,y), (x,z), (y,z)
      const T a = (e & 1) ? -s2 : s2, b = (e & 2) ? -s2 : s2;
      d[0] = pair == 2 ? T(0) : a;
      d[1] = pair == 0 ? b : (pair == 1 ? T(0) : a);
      d[2] = pair == 0 ? T(0) : b;
      w = T(4) / T(105);
    } else {
      const int c = j - 18;
      d[0] = (c & 1) ? -s3 : s3;
      d[1] = (c & 2) ? -s3 : s3;
      d[2] = (c & 4) ? -s3 : s3;
      w = T(9) / T(280);
    }
    // R^T d.
    const T r[3] = {R[0][0] * d[0] + R[1][0] * d[1] + R[2][0] * d[2], R[0][1] * d[0] + R[1][1] * d[1] + R[2][1] * d[2],
                    R[0][2] * d[0] + R[1][2] * d[1] + R[2][2] * d[2]};
    T b[16] = {}, br[16] = {};  // zero: the compiler cannot see that only `degree` entries are read
    shBasis(degree, d, b);
    shBasis(degree, r, br);
    const T wf = four_pi * w;
    for (int k = 0; k < 3; ++k)
      for (int m = 0; m < 3; ++m) out.m1[k][m] += wf * b[1 + k] * br[1 + m];
    if (degree < 2) continue;
    for (int k = 0; k < 5; ++k)
      for (int m = 0; m < 5; ++m) out.m2[k][m] += wf * b[4 + k] * br[4 + m];
    if (degree < 3) continue;
    for (int k = 0; k < 7; ++k)
      for (int m = 0; m < 7; ++m) out.m3[k][m] += wf * b[9 + k] * br[9 + m];
  }
}

/// Rotates one Gaussian's SH coefficients in place (`sh`: shCoeffCount(degree) x RGB,
/// coefficient-major, as in the maps) with blocks built by shRotation for at least `degree`.
template <typename T>
DYPHO_HOST_DEVICE inline void rotateSh(const ShRotation<T>& rot, int degree, T* sh) {
  for (int ch = 0; ch < 3; ++ch) {
    if (degree >= 1) {
      T in[3], o[3];
      for (int m = 0; m < 3; ++m) in[m] = sh[3 * (1 + m) + ch];
      for (int k = 0; k < 3; ++k) {
        o[k] = T(0);
        for (int m = 0; m < 3; ++m) o[k] += rot.m1[k][m] * in[m];
      }
      for (int k = 0; k < 3; ++k) sh[3 * (1 + k) + ch] = o[k];
    }
    if (degree >= 2) {
      T in[5], o[5];
      for (int m = 0; m < 5; ++m) in[m] = sh[3 * (4 + m) + ch];
      for (int k = 0; k < 5; ++k) {
        o[k] = T(0);
        for (int m = 0; m < 5; ++m) o[k] += rot.m2[k][m] * in[m];
      }
      for (int k = 0; k < 5; ++k) sh[3 * (4 + k) + ch] = o[k];
    }
    if (degree >= 3) {
      T in[7], o[7];
      for (int m = 0; m < 7; ++m) in[m] = sh[3 * (9 + m) + ch];
      for (int k = 0; k < 7; ++k) {
        o[k] = T(0);
        for (int m = 0; m < 7; ++m) o[k] += rot.m3[k][m] * in[m];
      }
      for (int k = 0; k < 7; ++k) sh[3 * (9 + k) + ch] = o[k];
    }
  }
}

}  // namespace dypho::mapping::gs
