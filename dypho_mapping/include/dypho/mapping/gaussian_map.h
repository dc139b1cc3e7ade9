#pragma once
/// \file gaussian_map.h
/// Structure-of-arrays storage of 3D Gaussians with a bounded capacity and ids that stay stable
/// when Gaussians are removed.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

namespace dypho::mapping {

/// The trainable parameter blocks of a Gaussian (rows of the SoA storage).
enum GaussianParam : int {
  kParamPosition = 0,  ///< world position x y z [m]
  kParamLogScale = 1,  ///< log of the three standard deviations along the local axes [log m]
  kParamRotation = 2,  ///< quaternion w x y z (world from local), normalised when used
  kParamOpacity = 3,   ///< opacity logit (opacity = sigmoid(logit))
  kParamSh = 4,        ///< SH colour, K coefficients x RGB, coefficient-major; DC first
  kNumGaussianParams = 5
};

/// One Gaussian to add (what seeding and loading produce).
struct GaussianInit {
  Eigen::Vector3f position_w = Eigen::Vector3f::Zero();          ///< world position [m]
  Eigen::Vector3f log_scale = Eigen::Vector3f::Constant(-4.6f);  ///< log std dev [log m]
  Eigen::Vector4f rotation_wxyz{1.f, 0.f, 0.f, 0.f};             ///< world-from-local quaternion
  float opacity_logit = 0.f;                                     ///< logit (0 = opacity 0.5)
  /// SH coefficients, coefficient-major RGB; empty = grey. When shorter than the map's count
  /// the rest are zero. Use `rgbToShDc` for a plain colour.
  std::vector<float> sh;
  std::int64_t anchor_keyframe_id = -1;  ///< keyframe whose pose the Gaussian follows (-1 none)
};

/// SH DC coefficient that renders as `value` in [0, 1] (inverse of 0.5 + C0 * dc).
float rgbToShDc(float value);

/// Gaussian storage. Not thread-safe. Arrays never reallocate (capacity reserved up front).
class GaussianMap {
 public:
  /// `sh_degree` in [0, 3]; `capacity` >= 1 Gaussians. Throws std::invalid_argument otherwise.
  GaussianMap(int sh_degree, std::size_t capacity);

  std::size_t size() const { return ids_.size(); }                      ///< Gaussians stored
  std::size_t capacity() const { return capacity_; }                    ///< the cap
  int shDegree() const { return sh_degree_; }                           ///< SH degree
  int shCoeffs() const { return (sh_degree_ + 1) * (sh_degree_ + 1); }  ///< K per channel
  /// Floats per Gaussian in parameter block `p`.
  int width(int p) const { return widths_[p]; }

  /// Appends a Gaussian; returns its id, or -1 when the map is full (nothing added).
  std::int64_t add(const GaussianInit& init);
  /// Appends a copy of Gaussian `index` (new id) and returns the new index, or -1 when full.
  long duplicate(std::size_t index);

  /// Removes the Gaussians with remove[i] != 0, keeping the order of the others (and their ids).
  void removeIf(const std::vector<std::uint8_t>& remove);

  /// Applies the rigid correction `T_new_old` to the Gaussians anchored at `keyframe_id`:
  /// positions, orientations and the view-dependent SH coefficients (rotated with the Gaussian,
  /// so it looks the same from the correspondingly moved camera). Returns how many moved.
  std::size_t transformAnchored(std::int64_t keyframe_id, const Eigen::Isometry3d& T_new_old);

  /// Removes every Gaussian (capacity and id counter kept).
  void clear();

  float* data(int p) { return params_[p].data(); }                       ///< block p, size()*width(p)
  const float* data(int p) const { return params_[p].data(); }           ///< block p
  std::vector<float>& block(int p) { return params_[p]; }                ///< block p as a vector
  const std::vector<std::int64_t>& ids() const { return ids_; }          ///< stable ids
  const std::vector<std::int64_t>& anchors() const { return anchors_; }  ///< anchor keyframe ids

  /// Keeps rows of a per-Gaussian array of width `w` where remove == 0 (same order).
  template <typename V>
  static void compactRows(std::vector<V>& v, int w, const std::vector<std::uint8_t>& remove) {
    std::size_t out = 0;
    const std::size_t n = remove.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (remove[i]) continue;
      if (out != i)
        for (int k = 0; k < w; ++k) v[out * w + k] = v[i * w + k];
      ++out;
    }
    v.resize(out * w);
  }

 private:
  int sh_degree_;
  std::size_t capacity_;
  std::array<int, kNumGaussianParams> widths_{};
  std::array<std::vector<float>, kNumGaussianParams> params_;
  std::vector<std::int64_t> ids_;
  std::vector<std::int64_t> anchors_;
  std::int64_t next_id_ = 0;
};

}  // namespace dypho::mapping
