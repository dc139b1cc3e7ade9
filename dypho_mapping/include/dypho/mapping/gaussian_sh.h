#pragma once
/// \file gaussian_sh.h
/// Real spherical harmonics of degree 0-3 (the 3DGS basis and sign convention) and their
/// derivatives, as inline host+device templates. Part of the per-Gaussian math (gaussian_math.h).

#include "dypho/mapping/host_device.h"

namespace dypho::mapping::gs {

/// Coefficients per colour channel for an SH degree.
DYPHO_HOST_DEVICE constexpr int shCoeffCount(int degree) { return (degree + 1) * (degree + 1); }

/// Real SH basis (3DGS constants and sign convention) of the unit direction d, `count` values.
template <typename T>
DYPHO_HOST_DEVICE inline void shBasis(int degree, const T* d, T* b) {
  const T x = d[0], y = d[1], z = d[2];
  b[0] = T(0.28209479177387814);
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
  db[4][0] = a0 * y; db[4][1] = a0 * x;
  db[5][1] = -a0 * z; db[5][2] = -a0 * y;
  db[6][0] = -T(2) * a2 * x; db[6][1] = -T(2) * a2 * y; db[6][2] = T(4) * a2 * z;
  db[7][0] = -a0 * z; db[7][2] = -a0 * x;
  db[8][0] = T(2) * a4 * x; db[8][1] = -T(2) * a4 * y;
  if (degree < 3) return;
  const T c0 = T(-0.5900435899266435), c1 = T(2.890611442640554), c2 = T(-0.4570457994644658),
          c3 = T(0.3731763325901154), c5 = T(1.445305721320277);
  db[9][0] = c0 * T(6) * x * y; db[9][1] = c0 * (T(3) * xx - T(3) * yy);
  db[10][0] = c1 * y * z; db[10][1] = c1 * x * z; db[10][2] = c1 * x * y;
  db[11][0] = c2 * (-T(2) * x * y); db[11][1] = c2 * (T(4) * zz - xx - T(3) * yy); db[11][2] = c2 * T(8) * y * z;
  db[12][0] = c3 * (-T(6) * x * z); db[12][1] = c3 * (-T(6) * y * z); db[12][2] = c3 * (T(6) * zz - T(3) * xx - T(3) * yy);
  db[13][0] = c2 * (T(4) * zz - T(3) * xx - yy); db[13][1] = c2 * (-T(2) * x * y); db[13][2] = c2 * T(8) * x * z;
  db[14][0] = c5 * T(2) * x * z; db[14][1] = c5 * (-T(2) * y * z); db[14][2] = c5 * (xx - yy);
  db[15][0] = c0 * (T(3) * xx - T(3) * yy); db[15][1] = c0 * (-T(6) * x * y);
}

}  // namespace dypho::mapping::gs
