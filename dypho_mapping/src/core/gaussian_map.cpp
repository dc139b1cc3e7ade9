#include "dypho/mapping/gaussian_map.h"

#include <stdexcept>
#include <string>

#include "dypho/mapping/gaussian_sh.h"

namespace dypho::mapping {

float rgbToShDc(float value) { return (value - 0.5f) / static_cast<float>(gs::kShC0); }

GaussianMap::GaussianMap(int sh_degree, std::size_t capacity) : sh_degree_(sh_degree), capacity_(capacity) {
  if (sh_degree < 0 || sh_degree > 3) {
    throw std::invalid_argument("GaussianMap: sh_degree must be in [0, 3], got " + std::to_string(sh_degree));
  }
  if (capacity < 1) throw std::invalid_argument("GaussianMap: capacity must be >= 1");
  widths_ = {3, 3, 4, 1, 3 * shCoeffs()};
  for (int p = 0; p < kNumGaussianParams; ++p) params_[p].reserve(capacity * widths_[p]);
  ids_.reserve(capacity);
  anchors_.reserve(capacity);
}

std::int64_t GaussianMap::add(const GaussianInit& g) {
  if (size() >= capacity_) return -1;
  auto& pos = params_[kParamPosition];
  pos.insert(pos.end(), {g.position_w.x(), g.position_w.y(), g.position_w.z()});
  auto& sc = params_[kParamLogScale];
  sc.insert(sc.end(), {g.log_scale.x(), g.log_scale.y(), g.log_scale.z()});
  auto& rot = params_[kParamRotation];
  rot.insert(rot.end(), {g.rotation_wxyz[0], g.rotation_wxyz[1], g.rotation_wxyz[2], g.rotation_wxyz[3]});
  params_[kParamOpacity].push_back(g.opacity_logit);
  auto& sh = params_[kParamSh];
  for (int k = 0; k < widths_[kParamSh]; ++k) sh.push_back(k < static_cast<int>(g.sh.size()) ? g.sh[k] : 0.f);
  ids_.push_back(next_id_);
  anchors_.push_back(g.anchor_keyframe_id);
  return next_id_++;
}

long GaussianMap::duplicate(std::size_t index) {
  if (size() >= capacity_ || index >= size()) return -1;
  for (int p = 0; p < kNumGaussianParams; ++p) {
    auto& v = params_[p];
    const int w = widths_[p];
    for (int k = 0; k < w; ++k) v.push_back(v[index * w + k]);
  }
  ids_.push_back(next_id_++);
  anchors_.push_back(anchors_[index]);
  return static_cast<long>(size() - 1);
}

void GaussianMap::removeIf(const std::vector<std::uint8_t>& remove) {
  if (remove.size() != size()) throw std::invalid_argument("GaussianMap::removeIf: mask size differs from size()");
  for (int p = 0; p < kNumGaussianParams; ++p) compactRows(params_[p], widths_[p], remove);
  compactRows(ids_, 1, remove);
  compactRows(anchors_, 1, remove);
}

std::size_t GaussianMap::transformAnchored(std::int64_t keyframe_id, const Eigen::Isometry3d& T_new_old) {
  const Eigen::Matrix3f R = T_new_old.linear().cast<float>();
  const Eigen::Vector3f t = T_new_old.translation().cast<float>();
  const Eigen::Quaternionf qR(R);
  // View-dependent colour turns with the Gaussian: c_new(R d) = c_old(d).
  gs::ShRotation<float> sh_rot;
  float Rm[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Rm[r][c] = R(r, c);
  if (sh_degree_ > 0) gs::shRotation(Rm, sh_degree_, sh_rot);
  const int sh_width = widths_[kParamSh];
  std::size_t moved = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (anchors_[i] != keyframe_id) continue;
    Eigen::Map<Eigen::Vector3f> p(&params_[kParamPosition][3 * i]);
    p = R * p + t;
    float* q = &params_[kParamRotation][4 * i];
    const Eigen::Quaternionf qn = qR * Eigen::Quaternionf(q[0], q[1], q[2], q[3]);
    q[0] = qn.w();
    q[1] = qn.x();
    q[2] = qn.y();
    q[3] = qn.z();
    if (sh_degree_ > 0) gs::rotateSh(sh_rot, sh_degree_, &params_[kParamSh][sh_width * i]);
    ++moved;
  }
  return moved;
}

void GaussianMap::clear() {
  for (auto& v : params_) v.clear();
  ids_.clear();
  anchors_.clear();
}

}  // namespace dypho::mapping
