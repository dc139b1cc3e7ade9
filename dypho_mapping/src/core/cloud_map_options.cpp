#include "dypho/mapping/cloud_map_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace dypho {
namespace mapping {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("CloudMapOptions: " + what);
}

}  // namespace

void CloudMapOptions::validate() const {
  require(pixel_stride >= 1, "pixel_stride must be >= 1, got " + std::to_string(pixel_stride));
  require(std::isfinite(min_depth_m) && min_depth_m >= 0.0,
          "min_depth_m must be >= 0, got " + std::to_string(min_depth_m));
  require(std::isfinite(max_depth_m) && max_depth_m > min_depth_m, "max_depth_m must be finite and > min_depth_m (" +
                                                                       std::to_string(min_depth_m) + "), got " +
                                                                       std::to_string(max_depth_m));
  require(std::isfinite(voxel_size_m) && voxel_size_m >= 0.0,
          "voxel_size_m must be >= 0 (0 disables the filter), got " + std::to_string(voxel_size_m));
  require(max_points >= 1, "max_points must be >= 1, got 0");
}

std::string CloudMapOptions::toString() const {
  std::ostringstream s;
  s << "pixel_stride=" << pixel_stride << " min_depth_m=" << min_depth_m << " max_depth_m=" << max_depth_m
    << " voxel_size_m=" << voxel_size_m << " max_points=" << max_points;
  return s.str();
}

}  // namespace mapping
}  // namespace dypho
