/// The map scored at the sequence's frames: PSNR, SSIM, depth L1 and coverage on static pixels.
#include "dypho/mapping/view_evaluation.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "dypho/common/atomic_file.h"
#include "dypho/mapping/ssim_math.h"

namespace dypho::mapping {
namespace {

/// Pixels scored: not dynamic after the dilation (255 = scored).
cv::Mat staticPixels(const cv::Mat& dynamic_mask, const cv::Size& size, int dilation_px) {
  if (dynamic_mask.empty()) return cv::Mat(size, CV_8UC1, cv::Scalar(255));
  cv::Mat grown;  // a new buffer: the caller's mask is never written
  if (dilation_px > 0) {
    const cv::Mat disk =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * dilation_px + 1, 2 * dilation_px + 1));
    cv::dilate(dynamic_mask, grown, disk);
  } else {
    grown = dynamic_mask;
  }
  cv::Mat scored;
  cv::compare(grown, 0, scored, cv::CMP_EQ);
  return scored;
}

/// Per-pixel SSIM of two single-channel float images in [0, 1] (ssim_math.h's window and formula).
cv::Mat ssimMap(const cv::Mat& x, const cv::Mat& y) {
  const ssim::Taps<float> taps = ssim::windowTaps<float>();
  const cv::Mat kernel(1, ssim::kWindow, CV_32FC1, const_cast<float*>(taps.t));
  const auto blur = [&](const cv::Mat& in) {
    cv::Mat out;
    cv::sepFilter2D(in, out, CV_32F, kernel, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
    return out;
  };
  const cv::Mat mx = blur(x), my = blur(y), exx = blur(x.mul(x)), eyy = blur(y.mul(y)), exy = blur(x.mul(y));
  cv::Mat s(x.size(), CV_32FC1);
  for (int v = 0; v < x.rows; ++v) {
    for (int u = 0; u < x.cols; ++u) {
      s.at<float>(v, u) = ssim::pixelSsim<float>(mx.at<float>(v, u), my.at<float>(v, u), exx.at<float>(v, u),
                                                 eyy.at<float>(v, u), exy.at<float>(v, u), 1.f)
                              .S;
    }
  }
  return s;
}

void checkInputs(const RenderedView& rendered, const cv::Mat& bgr, const cv::Mat& depth_m, const cv::Mat& mask) {
  const cv::Size size = rendered.bgr.size();
  if (rendered.bgr.type() != CV_8UC3 || rendered.alpha.type() != CV_32FC1 || rendered.depth_m.type() != CV_32FC1 ||
      rendered.alpha.size() != size || rendered.depth_m.size() != size) {
    throw std::invalid_argument("scoreView: the rendered view is incomplete (colour, depth and alpha needed)");
  }
  if (bgr.type() != CV_8UC3 || bgr.size() != size)
    throw std::invalid_argument("scoreView: bgr must be CV_8UC3 of the render's size");
  if (depth_m.type() != CV_32FC1 || depth_m.size() != size)
    throw std::invalid_argument("scoreView: depth_m must be CV_32FC1 of the render's size");
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != size))
    throw std::invalid_argument("scoreView: the dynamic mask must be empty or CV_8UC1 of the render's size");
}

ViewSummary meanOf(const std::vector<ViewScore>& views, bool keyframes, bool novel) {
  ViewSummary s;
  for (const ViewScore& v : views) {
    if ((v.keyframe && !keyframes) || (!v.keyframe && !novel) || v.static_pixels == 0) continue;
    ++s.views;
    s.psnr_db += v.psnr_db;
    s.ssim += v.ssim;
    s.depth_l1_m += v.depth_l1_m;
    s.coverage += v.coverage;
  }
  if (s.views > 0) {
    const double n = static_cast<double>(s.views);
    s.psnr_db /= n;
    s.ssim /= n;
    s.depth_l1_m /= n;
    s.coverage /= n;
  }
  return s;
}

void printSummary(std::ostream& os, const char* label, const ViewSummary& s) {
  os << label << std::setw(4) << s.views << " views: PSNR " << std::setprecision(2) << s.psnr_db << " dB, SSIM "
     << std::setprecision(3) << s.ssim << ", depth L1 " << std::setprecision(2) << s.depth_l1_m * 100.0
     << " cm, coverage " << std::setprecision(1) << s.coverage * 100.0 << " %\n";
}

}  // namespace

void ViewEvaluationOptions::validate() const {
  if (every_nth_frame < 1) throw std::invalid_argument("every_nth_frame must be >= 1 (default 10)");
  if (mask_dilation_px < 0) throw std::invalid_argument("mask_dilation_px must be >= 0 (default 5)");
  if (!(coverage_min_alpha > 0.f && coverage_min_alpha <= 1.f))
    throw std::invalid_argument("coverage_min_alpha must be in (0, 1] (default 0.5)");
}

ViewScore scoreView(const RenderedView& rendered, const cv::Mat& bgr, const cv::Mat& depth_m,
                    const cv::Mat& dynamic_mask, const ViewEvaluationOptions& options) {
  options.validate();
  checkInputs(rendered, bgr, depth_m, dynamic_mask);
  ViewScore score;
  const cv::Mat scored = staticPixels(dynamic_mask, bgr.size(), options.mask_dilation_px);
  cv::Mat input_f, render_f;
  bgr.convertTo(input_f, CV_32FC3, 1.0 / 255.0);
  rendered.bgr.convertTo(render_f, CV_32FC3, 1.0 / 255.0);
  std::vector<cv::Mat> in_ch, re_ch;
  cv::split(input_f, in_ch);
  cv::split(render_f, re_ch);
  cv::Mat ssim_sum = cv::Mat::zeros(bgr.size(), CV_32FC1);
  for (int c = 0; c < 3; ++c) ssim_sum += ssimMap(re_ch[c], in_ch[c]);
  double se = 0.0, ssim_total = 0.0, depth_sum = 0.0;
  std::size_t n = 0, covered = 0, depth_n = 0;
  for (int v = 0; v < bgr.rows; ++v) {
    const std::uint8_t* m = scored.ptr<std::uint8_t>(v);
    const float* in_d = depth_m.ptr<float>(v);
    const float* re_d = rendered.depth_m.ptr<float>(v);
    const float* alpha = rendered.alpha.ptr<float>(v);
    const cv::Vec3f* in_c = input_f.ptr<cv::Vec3f>(v);
    const cv::Vec3f* re_c = render_f.ptr<cv::Vec3f>(v);
    const float* s = ssim_sum.ptr<float>(v);
    for (int u = 0; u < bgr.cols; ++u) {
      if (!m[u]) continue;
      ++n;
      const cv::Vec3f d = re_c[u] - in_c[u];
      se += static_cast<double>(d.dot(d));
      ssim_total += s[u] / 3.0;
      if (alpha[u] >= options.coverage_min_alpha) ++covered;
      if (std::isfinite(in_d[u]) && in_d[u] > 0.f && re_d[u] > 0.f) {
        depth_sum += std::abs(static_cast<double>(re_d[u]) - in_d[u]);
        ++depth_n;
      }
    }
  }
  score.static_pixels = n;
  if (n == 0) return score;
  const double mse = std::max(se / (3.0 * static_cast<double>(n)), 1e-10);
  score.psnr_db = 10.0 * std::log10(1.0 / mse);
  score.ssim = ssim_total / static_cast<double>(n);
  score.coverage = static_cast<double>(covered) / static_cast<double>(n);
  score.depth_l1_m = depth_n > 0 ? depth_sum / static_cast<double>(depth_n) : 0.0;
  return score;
}

ViewEvaluation summarizeViews(std::vector<ViewScore> views) {
  ViewEvaluation ev;
  ev.views = std::move(views);
  ev.all = meanOf(ev.views, true, true);
  ev.keyframes = meanOf(ev.views, true, false);
  ev.novel = meanOf(ev.views, false, true);
  return ev;
}

std::string ViewEvaluation::report() const {
  std::ostringstream os;
  os << std::fixed;
  printSummary(os, "map views:    all      ", all);
  printSummary(os, "              keyframes", keyframes);
  printSummary(os, "              novel    ", novel);
  return os.str();
}

void writeViewEvaluation(const std::string& path, const ViewEvaluation& evaluation) {
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "# The map rendered at the estimated pose of every Nth frame, scored on static pixels\n"
       << "# (the system's dynamic mask, dilated, left out); coverage: opacity >= 0.5.\n"
       << evaluation.report() << "# stamp_s keyframe static_pixels psnr_db ssim depth_l1_m coverage\n"
       << std::fixed;
    for (const ViewScore& v : evaluation.views) {
      os << std::setprecision(6) << static_cast<double>(v.stamp_ns) * 1e-9 << ' ' << (v.keyframe ? 1 : 0) << ' '
         << v.static_pixels << ' ' << std::setprecision(3) << v.psnr_db << ' ' << std::setprecision(4) << v.ssim << ' '
         << v.depth_l1_m << ' ' << v.coverage << '\n';
    }
  });
}

}  // namespace dypho::mapping
