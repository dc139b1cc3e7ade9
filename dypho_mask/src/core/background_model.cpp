#include "dypho/mask/background_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "dypho/common/rounding.h"
#include "mask_internal.h"

namespace dypho {
namespace mask {

using internal::valid;

void warpDepthForward(const cv::Mat& depth_prev_m, const CameraIntrinsics& camera, const Eigen::Isometry3d& T_cur_prev,
                      cv::Mat& depth_cur_m) {
  CV_Assert(depth_prev_m.type() == CV_32FC1 && camera.fx > 0.0 && camera.fy > 0.0);
  const float inf = std::numeric_limits<float>::infinity();
  cv::Mat zbuf(depth_prev_m.size(), CV_32FC1, cv::Scalar(inf));
  const Eigen::Matrix3f R = T_cur_prev.linear().cast<float>();
  const Eigen::Vector3f t = T_cur_prev.translation().cast<float>();
  const float fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const int w = depth_prev_m.cols, h = depth_prev_m.rows;
  for (int y = 0; y < h; ++y) {
    const float* d = depth_prev_m.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const float z = d[x];
      if (!valid(z)) continue;
      const Eigen::Vector3f X = R * Eigen::Vector3f(z * (x - cx) / fx, z * (y - cy) / fy, z) + t;
      if (X.z() <= 0.01f) continue;
      const float u_px = fx * X.x() / X.z() + cx, v_px = fy * X.y() / X.z() + cy;
      constexpr float kFar = 1e9f;  // far outside the image (and NaN): not rounded
      if (!(std::abs(u_px) < kFar && std::abs(v_px) < kFar)) continue;
      const int u = roundHalfAway(u_px), v = roundHalfAway(v_px);
      if (u < 0 || v < 0 || u >= w || v >= h) continue;
      float& zb = zbuf.at<float>(v, u);
      if (X.z() < zb) zb = X.z();
    }
  }
  // Fill splat holes and cracks (up to 3 px wide, where magnification spreads the splats) with the
  // nearest (minimum) depth of the 5x5 window. Only pixels inside the morphological closing of
  // the splatted pixels are filled: closing leaves the border of the known region where it is, so
  // B never creeps a pixel per frame into space that was never seen.
  cv::Mat filled, have, closed;
  const cv::Mat k5 = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5));
  cv::erode(zbuf, filled, k5, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(inf));
  cv::compare(zbuf, inf, have, cv::CMP_LT);
  cv::morphologyEx(have, closed, cv::MORPH_CLOSE, k5, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  depth_cur_m.create(depth_prev_m.size(), CV_32FC1);
  for (int y = 0; y < h; ++y) {
    const float* z = zbuf.ptr<float>(y);
    const float* f = filled.ptr<float>(y);
    const uchar* c = closed.ptr<uchar>(y);
    float* o = depth_cur_m.ptr<float>(y);
    for (int x = 0; x < w; ++x) o[x] = std::isfinite(z[x]) ? z[x] : (c[x] && std::isfinite(f[x]) ? f[x] : 0.f);
  }
}

void nearestWithin(const cv::Mat& depth_m, int radius_px, cv::Mat& nearest_m) {
  CV_Assert(depth_m.type() == CV_32FC1 && radius_px >= 0);
  if (radius_px == 0) {
    depth_m.copyTo(nearest_m);
    return;
  }
  const float inf = std::numeric_limits<float>::infinity();
  cv::Mat have, lifted;
  cv::compare(depth_m, 0.f, have, cv::CMP_GT);  // false for NaN
  lifted.create(depth_m.size(), CV_32FC1);
  lifted.setTo(inf);
  depth_m.copyTo(lifted, have);
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius_px + 1, 2 * radius_px + 1));
  cv::erode(lifted, nearest_m, disc, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(inf));
  nearest_m.setTo(0.f, ~have);
}

void depthConsistencyMask(const cv::Mat& background_m, const cv::Mat& depth_m, double sigma_m, int window,
                          int min_agreeing, cv::Mat& dynamic) {
  CV_Assert(background_m.type() == CV_32FC1 && depth_m.type() == CV_32FC1 && background_m.size() == depth_m.size() &&
            window >= 1 && window % 2 == 1);
  const int r = window / 2, w = depth_m.cols, h = depth_m.rows;
  const float sigma = static_cast<float>(sigma_m);
  const float inf = std::numeric_limits<float>::infinity();
  // Per window: number of valid depths, their minimum (invalid = +inf) and maximum (invalid = 0).
  // All valid neighbours agree when min >= limit, none when max < limit; only windows in between
  // (object borders) need the per-neighbour count. Both shortcuts give the exact rule's answer.
  cv::Mat valid_u8, d_min_in, d_max_in, n_valid, d_min, d_max;
  cv::compare(depth_m, 0.f, valid_u8, cv::CMP_GT);  // false for NaN
  cv::boxFilter(valid_u8 / 255, n_valid, CV_16U, cv::Size(window, window), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  depth_m.copyTo(d_max_in);
  d_max_in.setTo(0.f, ~valid_u8);
  d_min_in.create(depth_m.size(), CV_32FC1);
  d_min_in.setTo(inf);
  depth_m.copyTo(d_min_in, valid_u8);
  const cv::Mat kernel = cv::Mat::ones(window, window, CV_8UC1);
  cv::erode(d_min_in, d_min, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(inf));
  cv::dilate(d_max_in, d_max, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0.f));
  dynamic.create(depth_m.size(), CV_8UC1);
  for (int y = 0; y < h; ++y) {
    const float* b = background_m.ptr<float>(y);
    const float* lo = d_min.ptr<float>(y);
    const float* hi = d_max.ptr<float>(y);
    const ushort* nv = n_valid.ptr<ushort>(y);
    uchar* out = dynamic.ptr<uchar>(y);
    for (int x = 0; x < w; ++x) {
      out[x] = 0;
      if (!valid(b[x]) || nv[x] <= min_agreeing) continue;  // undecided
      const float limit = b[x] - sigma;
      if (lo[x] >= limit) continue;  // every valid neighbour agrees
      if (hi[x] < limit) {           // none agrees
        out[x] = 255;
        continue;
      }
      int n_agree = 0;
      for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy) {
        const float* d = depth_m.ptr<float>(yy);
        for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) n_agree += valid(d[xx]) && d[xx] >= limit;
      }
      if (n_agree <= min_agreeing) out[x] = 255;
    }
  }
}

void vetoRegionsOnBackground(const cv::Mat& background_m, const cv::Mat& depth_m, const cv::Mat& consistency_dynamic,
                             double sigma_m, double min_consistent_share, double min_checked_share, cv::Mat& raw) {
  cv::Mat labels;
  const int n = cv::connectedComponents(raw, labels, 8, CV_32S);
  if (n <= 1) return;
  std::vector<int> total(n, 0), checked(n, 0), consistent(n, 0), touches(n, 0);
  for (int y = 0; y < raw.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* b = background_m.ptr<float>(y);
    const float* d = depth_m.ptr<float>(y);
    const uchar* c = consistency_dynamic.ptr<uchar>(y);
    for (int x = 0; x < raw.cols; ++x) {
      if (l[x] == 0) continue;
      ++total[l[x]];
      touches[l[x]] += c[x] != 0;
      if (valid(b[x]) && valid(d[x])) {
        ++checked[l[x]];
        consistent[l[x]] += std::abs(d[x] - b[x]) < sigma_m;
      }
    }
  }
  std::vector<bool> drop(n, false);
  for (int i = 1; i < n; ++i) {
    drop[i] = touches[i] == 0 && checked[i] >= min_checked_share * total[i] && checked[i] > 0 &&
              consistent[i] >= min_consistent_share * checked[i];
  }
  for (int y = 0; y < raw.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    uchar* r = raw.ptr<uchar>(y);
    for (int x = 0; x < raw.cols; ++x)
      if (drop[l[x]]) r[x] = 0;
  }
}

void dropUnsupportedRegions(const cv::Mat& raw_dynamic, double min_support_share, cv::Mat& consistency_dynamic,
                            cv::Mat& cleared) {
  CV_Assert(
      consistency_dynamic.type() == CV_8UC1 &&
      (raw_dynamic.empty() || (raw_dynamic.type() == CV_8UC1 && raw_dynamic.size() == consistency_dynamic.size())));
  cleared.create(consistency_dynamic.size(), CV_8UC1);
  cleared.setTo(0);
  cv::Mat labels;
  const int regions = cv::connectedComponents(consistency_dynamic, labels, 8, CV_32S);
  if (regions <= 1) return;
  std::vector<int> area(static_cast<size_t>(regions), 0), supported(static_cast<size_t>(regions), 0);
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const uchar* r = raw_dynamic.empty() ? nullptr : raw_dynamic.ptr<uchar>(y);
    for (int x = 0; x < labels.cols; ++x) {
      ++area[static_cast<size_t>(l[x])];
      if (r != nullptr && r[x] != 0) ++supported[static_cast<size_t>(l[x])];
    }
  }
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    uchar* c = consistency_dynamic.ptr<uchar>(y);
    uchar* out = cleared.ptr<uchar>(y);
    for (int x = 0; x < labels.cols; ++x) {
      const size_t k = static_cast<size_t>(l[x]);
      if (k == 0 || supported[k] >= min_support_share * area[k]) continue;
      c[x] = 0;
      out[x] = 255;
    }
  }
}

BackgroundModel::BackgroundModel(const BackgroundOptions& options) : options_((options.validate(), options)) {}

void BackgroundModel::process(const cv::Mat& depth_m, const cv::Mat& raw_dynamic, const cv::Mat& rendered_depth_m,
                              const CameraIntrinsics& camera, const std::optional<Eigen::Isometry3d>& T_prev_cur,
                              cv::Mat& dynamic, double image_motion_px) {
  CV_Assert(raw_dynamic.type() == CV_8UC1 && raw_dynamic.size() == depth_m.size());
  test(depth_m, rendered_depth_m, camera, T_prev_cur, dynamic);
  retest(depth_m, image_motion_px, dynamic);
  cv::bitwise_or(raw_dynamic, dynamic, excluded_);
  update(depth_m, rendered_depth_m, excluded_);
}

void BackgroundModel::test(const cv::Mat& depth_m, const cv::Mat& rendered_depth_m, const CameraIntrinsics& camera,
                           const std::optional<Eigen::Isometry3d>& T_prev_cur, cv::Mat& dynamic) {
  CV_Assert(depth_m.type() == CV_32FC1);
  const cv::Size size = depth_m.size();
  if (background_.size() != size) background_ = cv::Mat::zeros(size, CV_32FC1);
  warped_valid_ = T_prev_cur && camera.valid();
  if (warped_valid_) warpDepthForward(background_, camera, T_prev_cur->inverse(), warped_);
  const cv::Mat& previous = warped_valid_ ? warped_ : background_;
  const bool rendered =
      !rendered_depth_m.empty() && rendered_depth_m.size() == size && rendered_depth_m.type() == CV_32FC1;
  // Prior Q: the B_{i-1} and R_d terms, renormalised over the available ones.
  const float wb = static_cast<float>(1.0 - options_.tau - options_.rho);
  const float wr = static_cast<float>(options_.tau);
  if (!rendered) {
    previous.copyTo(prior_);  // one term: Q = B_{i-1} (0 where none)
  } else {
    prior_.create(size, CV_32FC1);
    for (int y = 0; y < size.height; ++y) {
      const float* p = previous.ptr<float>(y);
      const float* rd = rendered_depth_m.ptr<float>(y);
      float* q = prior_.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        float num = 0.f, den = 0.f;
        if (valid(p[x])) {
          num += wb * p[x];
          den += wb;
        }
        if (valid(rd[x])) {
          num += wr * rd[x];
          den += wr;
        }
        q[x] = den > 0.f ? num / den : 0.f;
      }
    }
  }
  depthConsistencyMask(prior_, depth_m, options_.sigma_m, options_.window_px, options_.min_agreeing, dynamic);
}

bool BackgroundModel::retest(const cv::Mat& depth_m, double image_motion_px, cv::Mat& dynamic) {
  // A depth edge of the carried prior may be off by a share of the frame's image motion.
  // (NaN or negative motion: none; more than the image is no more tolerant than the image.)
  const double motion_px = std::clamp(std::isfinite(image_motion_px) ? image_motion_px : 0.0, 0.0, 1e4);
  const int radius_px = static_cast<int>(std::lround(options_.motion_tolerance * motion_px));
  if (radius_px == 0 || prior_.empty() || prior_.size() != depth_m.size()) return false;
  nearestWithin(prior_, radius_px, tested_);
  depthConsistencyMask(tested_, depth_m, options_.sigma_m, options_.window_px, options_.min_agreeing, dynamic);
  return true;
}

void BackgroundModel::update(const cv::Mat& depth_m, const cv::Mat& rendered_depth_m, const cv::Mat& excluded) {
  const cv::Size size = depth_m.size();
  CV_Assert(depth_m.type() == CV_32FC1 && excluded.type() == CV_8UC1 && excluded.size() == size &&
            prior_.size() == size && background_.size() == size);
  const cv::Mat& previous = warped_valid_ ? warped_ : background_;
  const bool rendered =
      !rendered_depth_m.empty() && rendered_depth_m.size() == size && rendered_depth_m.type() == CV_32FC1;
  const float wb = static_cast<float>(1.0 - options_.tau - options_.rho);
  const float wr = static_cast<float>(options_.tau), wd = static_cast<float>(options_.rho);
  // B_i: add D_i where it is static by every mask; take D_i outright where it is farther. When
  // previous is background_ itself, each pixel reads its old value before writing it.
  const float sigma = static_cast<float>(options_.sigma_m);
  for (int y = 0; y < size.height; ++y) {
    const float* p = previous.ptr<float>(y);
    const float* rd = rendered ? rendered_depth_m.ptr<float>(y) : nullptr;
    const float* d = depth_m.ptr<float>(y);
    const float* q = prior_.ptr<float>(y);
    const uchar* ex = excluded.ptr<uchar>(y);
    float* b = background_.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      const bool d_ok = valid(d[x]) && ex[x] == 0;
      if (d_ok && valid(q[x]) && d[x] > q[x] + sigma) {
        b[x] = d[x];
        continue;
      }
      float num = 0.f, den = 0.f;
      if (valid(p[x])) {
        num += wb * p[x];
        den += wb;
      }
      if (rd && valid(rd[x])) {
        num += wr * rd[x];
        den += wr;
      }
      if (d_ok) {
        num += wd * d[x];
        den += wd;
      }
      b[x] = den > 0.f ? num / den : 0.f;
    }
  }
}

void BackgroundModel::relearn(const cv::Mat& depth_m, const cv::Mat& pixels) {
  CV_Assert(depth_m.type() == CV_32FC1 && pixels.type() == CV_8UC1 && pixels.size() == depth_m.size());
  if (background_.size() != depth_m.size()) return;
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* d = depth_m.ptr<float>(y);
    const uchar* m = pixels.ptr<uchar>(y);
    float* b = background_.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      if (m[x] != 0 && valid(d[x])) b[x] = d[x];
    }
  }
}

}  // namespace mask
}  // namespace dypho
