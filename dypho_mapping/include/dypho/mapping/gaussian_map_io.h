#pragma once
/// \file gaussian_map_io.h
/// Files of a Gaussian map: the standard 3DGS PLY (gaussian_ply.h) and a PCD of the centres,
/// written atomically (temporary file + rename).

#include <cstdint>
#include <string>
#include <vector>

#include "dypho/mapping/gaussian_map.h"

namespace dypho::mapping {

/// One Gaussian centre with its colour (for point clouds).
struct GaussianCentre {
  float x, y, z;         ///< world [m]
  std::uint8_t r, g, b;  ///< DC colour
};

/// Centres and DC colours of all Gaussians of `map`.
std::vector<GaussianCentre> gaussianCentres(const GaussianMap& map);

/// Writes `map` as a 3DGS PLY, atomically. Throws std::runtime_error naming the path.
void saveGaussianPly(const std::string& path, const GaussianMap& map);

/// Reads a 3DGS PLY into a new map of `sh_degree` and `capacity` (Gaussians not anchored to
/// keyframes). Throws std::runtime_error naming the problem; `note` (optional) says what was
/// adapted (see readGaussianPly).
GaussianMap loadGaussianPly(const std::string& path, int sh_degree, std::size_t capacity, std::string* note = nullptr);

/// Writes `centres` as a binary PCD (x y z rgb), atomically.
void saveCentresPcd(const std::string& path, const std::vector<GaussianCentre>& centres);

}  // namespace dypho::mapping
