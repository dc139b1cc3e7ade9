#include "dypho/mask/global_motion.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

namespace dypho {
namespace mask {
namespace {

bool finite(const cv::Vec2f& v) { return std::isfinite(v[0]) && std::isfinite(v[1]); }

}  // namespace

GlobalMotionEstimator::GlobalMotionEstimator(const GlobalMotionSettings& settings) : settings_(settings) {}

GlobalMotionFit GlobalMotionEstimator::fit(const cv::Mat& cur, const cv::Mat& prev, const cv::Mat& usable) {
  GlobalMotionFit out;
  if (cur.empty() || cur.type() != CV_32FC2 || prev.type() != CV_32FC2 || prev.size() != cur.size()) {
    out.message = "correspondence fields must be non-empty CV_32FC2 images of equal size";
    return out;
  }
  if (!usable.empty() && (usable.type() != CV_8UC1 || usable.size() != cur.size())) {
    out.message = "usable mask must be CV_8UC1 of the correspondence fields' size";
    return out;
  }
  const int step = std::max(1, settings_.sample_step);
  src_.clear();
  dst_.clear();
  for (int y = step / 2; y < cur.rows; y += step) {
    const cv::Vec2f* c = cur.ptr<cv::Vec2f>(y);
    const cv::Vec2f* p = prev.ptr<cv::Vec2f>(y);
    const unsigned char* ok = usable.empty() ? nullptr : usable.ptr<unsigned char>(y);
    for (int x = step / 2; x < cur.cols; x += step) {
      if ((ok != nullptr && ok[x] == 0) || !finite(c[x]) || !finite(p[x])) continue;
      src_.emplace_back(c[x][0], c[x][1]);
      dst_.emplace_back(p[x][0], p[x][1]);
    }
  }
  out.num_samples = static_cast<int>(src_.size());
  if (out.num_samples < 8) {
    out.message = "only " + std::to_string(out.num_samples) +
                  " usable flow samples (textureless image, or image too small for the sample "
                  "step?)";
    return out;
  }
  cv::Mat H = cv::findHomography(src_, dst_, cv::RANSAC, settings_.ransac_threshold_px, inliers_,
                                 settings_.max_iterations, 0.995);
  if (H.empty()) {
    out.message = "homography fit failed (degenerate flow field)";
    return out;
  }
  for (unsigned char v : inliers_) out.num_inliers += v ? 1 : 0;
  H.convertTo(H, CV_64F);
  out.H_prev_cur = cv::Matx33d(H.ptr<double>());
  if (out.inlierRatio() < settings_.min_inlier_ratio) {
    out.message = "only " + std::to_string(out.num_inliers) + " of " + std::to_string(out.num_samples) +
                  " flow samples follow one global motion (moving objects cover most of the "
                  "view, or the flow is bad)";
    return out;
  }
  out.ok = true;
  return out;
}

void computeResidualMagnitude(const cv::Mat& cur, const cv::Mat& prev, const cv::Matx33d& H, cv::Mat& residual_px,
                              cv::Mat* residual_vec_px) {
  CV_Assert(cur.type() == CV_32FC2 && prev.type() == CV_32FC2 && cur.size() == prev.size());
  residual_px.create(cur.size(), CV_32FC1);
  if (residual_vec_px) residual_vec_px->create(cur.size(), CV_32FC2);
  for (int y = 0; y < cur.rows; ++y) {
    const cv::Vec2f* c = cur.ptr<cv::Vec2f>(y);
    const cv::Vec2f* p = prev.ptr<cv::Vec2f>(y);
    float* r = residual_px.ptr<float>(y);
    cv::Vec2f* rv = residual_vec_px ? residual_vec_px->ptr<cv::Vec2f>(y) : nullptr;
    for (int x = 0; x < cur.cols; ++x) {
      if (rv) rv[x] = cv::Vec2f(0.f, 0.f);
      if (!finite(c[x]) || !finite(p[x])) {
        r[x] = 0.f;
        continue;
      }
      const double u = c[x][0], v = c[x][1];
      const double w = H(2, 0) * u + H(2, 1) * v + H(2, 2);
      if (std::abs(w) < 1e-12) {
        r[x] = 0.f;
        continue;
      }
      const double dx = p[x][0] - (H(0, 0) * u + H(0, 1) * v + H(0, 2)) / w;
      const double dy = p[x][1] - (H(1, 0) * u + H(1, 1) * v + H(1, 2)) / w;
      r[x] = static_cast<float>(std::sqrt(dx * dx + dy * dy));
      if (rv) rv[x] = cv::Vec2f(static_cast<float>(dx), static_cast<float>(dy));
    }
  }
}

}  // namespace mask
}  // namespace dypho
