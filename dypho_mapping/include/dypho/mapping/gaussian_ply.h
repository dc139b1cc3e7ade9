#pragma once
/// \file gaussian_ply.h
/// The standard 3D Gaussian Splatting PLY layout (binary little endian, float32):
/// `x y z nx ny nz f_dc_0..2 f_rest_0..(3(K-1)-1) opacity scale_0..2 rot_0..3`, where f_rest is
/// channel-major (all R coefficients, then G, then B), opacity is the logit, scale the log std dev
/// and rot the quaternion w x y z. Readable by common 3DGS viewers.

#include <cstddef>
#include <ostream>
#include <string>

#include "dypho/mapping/gaussian_map.h"

namespace dypho::mapping {

/// Writes `map` to `out` (normals are written as 0).
void writeGaussianPly(std::ostream& out, const GaussianMap& map);

/// Reads a 3DGS PLY into `map` (cleared first; Gaussians get new ids and no anchor). Properties
/// are found by name, in whatever order the file declares them; extra float properties are
/// ignored. SH degrees that differ from the map's are truncated or zero-padded. Gaussians beyond
/// the map's capacity are dropped; returns how many were read and `note` (optional) says what was adapted.
/// Throws std::runtime_error naming `path` and the problem (cannot open, not a PLY, not
/// binary_little_endian, a missing, repeated or non-float property, truncated data); `map` is then
/// unchanged. Nothing is allocated for the payload before the file is known to hold it.
std::size_t readGaussianPly(const std::string& path, GaussianMap& map, std::string* note = nullptr);

}  // namespace dypho::mapping
