// Procedural textures for the synthetic room: walls with posters, floor, ceiling, clothing.
// Everything is drawn with OpenCV primitives driven by one cv::RNG, so a seed fixes every texel.
#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "synthetic_internal.h"

namespace dypho::tools::synth_detail {
namespace {

int toPx(double m, double texel_m = kTexelM) { return std::max(1, static_cast<int>(std::lround(m / texel_m))); }

cv::Scalar randomColour(cv::RNG& rng, int lo = 0, int hi = 256) {
  return cv::Scalar(rng.uniform(lo, hi), rng.uniform(lo, hi), rng.uniform(lo, hi));
}

/// Smooth random field in [-1, 1] of the given size (bicubic upsampling of a coarse grid).
cv::Mat lowFrequencyField(cv::Size size, int cells_x, cv::RNG& rng) {
  const int cells_y = std::max(2, cells_x * size.height / std::max(1, size.width));
  cv::Mat coarse(cells_y + 1, cells_x + 1, CV_32FC1);
  rng.fill(coarse, cv::RNG::UNIFORM, -1.0, 1.0);
  cv::Mat field;
  cv::resize(coarse, field, size, 0, 0, cv::INTER_CUBIC);
  return field;
}

/// Base colour, low-frequency shading and fine plaster noise (amplitudes in grey levels).
cv::Mat baseSurface(cv::Size size, const cv::Scalar& colour, double low_amp, double noise_amp, cv::RNG& rng) {
  const cv::Mat low = lowFrequencyField(size, 8, rng);
  // Plaster grain: white noise at half resolution, bilinearly upsampled (= blurred by ~1 texel).
  cv::Mat half((size.height + 1) / 2, (size.width + 1) / 2, CV_32FC1), noise;
  rng.fill(half, cv::RNG::NORMAL, 0.0, noise_amp * 1.4);
  cv::resize(half, noise, size, 0, 0, cv::INTER_LINEAR);
  cv::Mat out(size, CV_8UC3);
  for (int v = 0; v < size.height; ++v) {
    const float* l = low.ptr<float>(v);
    const float* n = noise.ptr<float>(v);
    auto* o = out.ptr<cv::Vec3b>(v);
    for (int u = 0; u < size.width; ++u) {
      const double f = low_amp * l[u] + n[u];
      o[u] = cv::Vec3b(cv::saturate_cast<std::uint8_t>(colour[0] + f), cv::saturate_cast<std::uint8_t>(colour[1] + f),
                       cv::saturate_cast<std::uint8_t>(colour[2] + f));
    }
  }
  return out;
}

std::string randomWord(cv::RNG& rng) {
  static const char kChars[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789#&%@";
  const int len = rng.uniform(2, 9);
  std::string w;
  for (int i = 0; i < len; ++i) w += kChars[rng.uniform(0, static_cast<int>(sizeof(kChars) - 1))];
  return w;
}

void drawChecker(cv::Mat& roi, cv::RNG& rng) {
  const int cell = std::max(4, toPx(rng.uniform(0.025, 0.06)));
  const cv::Scalar a = randomColour(rng, 0, 120), b = randomColour(rng, 140, 256);
  for (int y = 0; y < roi.rows; y += cell) {
    for (int x = 0; x < roi.cols; x += cell) {
      cv::rectangle(roi, cv::Rect(x, y, cell, cell), ((x / cell + y / cell) % 2) ? a : b, cv::FILLED);
    }
  }
}

void drawCollage(cv::Mat& roi, cv::RNG& rng) {
  roi.setTo(randomColour(rng, 60, 256));
  const int n = rng.uniform(6, 16);
  for (int i = 0; i < n; ++i) {
    const int w = rng.uniform(roi.cols / 8 + 1, roi.cols / 2 + 2);
    const int h = rng.uniform(roi.rows / 8 + 1, roi.rows / 2 + 2);
    const cv::Rect r(rng.uniform(0, roi.cols), rng.uniform(0, roi.rows), w, h);
    cv::rectangle(roi, r, randomColour(rng), cv::FILLED);
  }
}

void drawBlobs(cv::Mat& roi, cv::RNG& rng) {
  roi.setTo(randomColour(rng, 150, 256));
  const int n = rng.uniform(8, 25);
  for (int i = 0; i < n; ++i) {
    const cv::Point c(rng.uniform(0, roi.cols), rng.uniform(0, roi.rows));
    const int a = rng.uniform(4, std::max(5, roi.cols / 5));
    const int b = rng.uniform(4, std::max(5, roi.rows / 5));
    cv::ellipse(roi, c, cv::Size(a, b), rng.uniform(0.0, 180.0), 0, 360, randomColour(rng, 0, 200), cv::FILLED,
                cv::LINE_AA);
  }
}

void drawText(cv::Mat& roi, cv::RNG& rng) {
  roi.setTo(randomColour(rng, 170, 256));
  const int fonts[] = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX, cv::FONT_HERSHEY_COMPLEX,
                       cv::FONT_HERSHEY_TRIPLEX, cv::FONT_HERSHEY_PLAIN};
  const int font = fonts[rng.uniform(0, 5)];
  const double letter_px = toPx(rng.uniform(0.03, 0.07));
  const double scale = letter_px / 22.0;
  const int thickness = std::max(2, static_cast<int>(letter_px / 7));
  const cv::Scalar ink = randomColour(rng, 0, 110);
  for (int y = static_cast<int>(letter_px * 1.5); y < roi.rows; y += static_cast<int>(letter_px * 1.8)) {
    int x = rng.uniform(2, static_cast<int>(letter_px) + 3);
    while (x < roi.cols) {
      const std::string w = randomWord(rng);
      cv::putText(roi, w, cv::Point(x, y), font, scale, ink, thickness, cv::LINE_AA);
      int base = 0;
      x += cv::getTextSize(w, font, scale, thickness, &base).width + static_cast<int>(letter_px);
    }
  }
}

void drawScribbles(cv::Mat& roi, cv::RNG& rng) {
  roi.setTo(randomColour(rng, 160, 256));
  const int n = rng.uniform(4, 10);
  for (int i = 0; i < n; ++i) {
    std::vector<cv::Point> pts;
    cv::Point p(rng.uniform(0, roi.cols), rng.uniform(0, roi.rows));
    for (int k = 0; k < 8; ++k) {
      pts.push_back(p);
      p += cv::Point(rng.uniform(-roi.cols / 4, roi.cols / 4 + 1), rng.uniform(-roi.rows / 4, roi.rows / 4 + 1));
    }
    cv::polylines(roi, pts, false, randomColour(rng, 0, 140), rng.uniform(3, 9), cv::LINE_AA);
  }
}

/// One framed poster of a random kind at a random place.
void drawPoster(cv::Mat& tex, cv::RNG& rng) {
  const int w = toPx(rng.uniform(0.18, 0.8));
  const int h = toPx(rng.uniform(0.18, 0.7));
  if (w + 4 >= tex.cols || h + 4 >= tex.rows) return;
  const cv::Rect r(rng.uniform(0, tex.cols - w), rng.uniform(0, tex.rows - h), w, h);
  cv::Mat roi = tex(r);
  switch (rng.uniform(0, 5)) {
    case 0:
      drawChecker(roi, rng);
      break;
    case 1:
      drawCollage(roi, rng);
      break;
    case 2:
      drawBlobs(roi, rng);
      break;
    case 3:
      drawText(roi, rng);
      break;
    default:
      drawScribbles(roi, rng);
      break;
  }
  cv::rectangle(tex, r, randomColour(rng, 0, 90), rng.uniform(3, 10));
}

}  // namespace

Texture::Texture(const cv::Mat& bgr, double texel_m) : texel_m_(texel_m) {
  CV_Assert(bgr.type() == CV_8UC3 && !bgr.empty() && texel_m > 0);
  levels_.push_back(bgr.clone());
  while (levels_.back().cols > 8 && levels_.back().rows > 8 && levels_.size() < 8) {
    cv::Mat next;
    cv::pyrDown(levels_.back(), next);
    levels_.push_back(next);
  }
}

namespace {
inline cv::Vec3f bilinear(const cv::Mat& img, double x, double y) {
  x = std::clamp(x, 0.0, img.cols - 1.001);
  y = std::clamp(y, 0.0, img.rows - 1.001);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  const cv::Vec3b* r0 = img.ptr<cv::Vec3b>(y0) + x0;
  const cv::Vec3b* r1 = img.ptr<cv::Vec3b>(y0 + 1) + x0;
  cv::Vec3f out;
  for (int c = 0; c < 3; ++c) {
    const float top = r0[0][c] + ax * (r0[1][c] - r0[0][c]);
    const float bot = r1[0][c] + ax * (r1[1][c] - r1[0][c]);
    out[c] = top + ay * (bot - top);
  }
  return out;
}
}  // namespace

cv::Vec3f Texture::sample(double u_m, double v_m, double footprint_m) const {
  const double level =
      std::clamp(std::log2(std::max(footprint_m / texel_m_, 1e-6)), 0.0, static_cast<double>(levels_.size() - 1));
  const int l0 = static_cast<int>(level);
  const int l1 = std::min<int>(l0 + 1, static_cast<int>(levels_.size()) - 1);
  const float w1 = static_cast<float>(level - l0);
  auto at = [&](int l) {
    const double s = 1.0 / (texel_m_ * static_cast<double>(1 << l));
    return bilinear(levels_[l], u_m * s - 0.5, v_m * s - 0.5);
  };
  cv::Vec3f c = at(l0);
  if (w1 > 0.f && l1 != l0) c = c * (1.f - w1) + at(l1) * w1;
  return c * (1.f / 255.f);
}

cv::Mat makeWallTexture(double width_m, double height_m, double poster_density, cv::RNG& rng) {
  const cv::Size size(toPx(width_m), toPx(height_m));
  cv::Mat tex = baseSurface(size, randomColour(rng, 110, 230), rng.uniform(10.0, 30.0), 7.0, rng);
  // A door or window frame gives large-scale corners.
  if (rng.uniform(0, 2) == 0 && width_m > 1.5) {
    const int w = toPx(rng.uniform(0.8, 1.2)), h = toPx(std::min(2.0, height_m * 0.7));
    const cv::Rect door(rng.uniform(0, size.width - w), size.height - h, w, h);
    tex(door).setTo(randomColour(rng, 40, 200));
    cv::rectangle(tex, door, randomColour(rng, 0, 80), toPx(0.04));
  }
  const int posters = static_cast<int>(std::lround(width_m * height_m * poster_density));
  for (int i = 0; i < posters; ++i) drawPoster(tex, rng);
  return tex;
}

cv::Mat makeFloorTexture(double width_m, double height_m, cv::RNG& rng) {
  const cv::Size size(toPx(width_m), toPx(height_m));
  cv::Mat tex = baseSurface(size, cv::Scalar(70, 110, 150), 15.0, 9.0, rng);
  // Planks of random width/length and shade: edges and plank ends give corners without a
  // strictly periodic pattern.
  for (int y = 0; y < size.height;) {
    const int ph = toPx(rng.uniform(0.12, 0.22));
    for (int x = -rng.uniform(0, toPx(1.0)); x < size.width;) {
      const int pw = toPx(rng.uniform(0.6, 1.6));
      const cv::Rect r = cv::Rect(x, y, pw, ph) & cv::Rect(0, 0, size.width, size.height);
      if (r.area() > 0) {
        cv::Mat roi = tex(r);
        roi += cv::Scalar::all(rng.uniform(-35, 35));
        cv::rectangle(tex, r, cv::Scalar(30, 50, 70), 2);
      }
      x += pw;
    }
    y += ph;
  }
  const int items = static_cast<int>(width_m * height_m * 0.8);
  for (int i = 0; i < items; ++i) drawPoster(tex, rng);  // rugs, mats, papers on the floor
  return tex;
}

cv::Mat makeCeilingTexture(double width_m, double height_m, cv::RNG& rng) {
  const cv::Size size(toPx(width_m), toPx(height_m));
  cv::Mat tex = baseSurface(size, cv::Scalar(215, 220, 225), 12.0, 5.0, rng);
  const int panel = toPx(0.6);
  for (int y = 0; y < size.height; y += panel) {
    for (int x = 0; x < size.width; x += panel) {
      cv::Mat roi = tex(cv::Rect(x, y, panel, panel) & cv::Rect(0, 0, size.width, size.height));
      roi -= cv::Scalar::all(rng.uniform(0, 25));
      if (rng.uniform(0, 6) == 0) roi.setTo(cv::Scalar(250, 250, 245));  // lamp
    }
  }
  for (int i = 0; i < static_cast<int>(width_m * height_m * 0.5); ++i) drawPoster(tex, rng);
  return tex;
}

cv::Mat makeClothingTexture(double circumference_m, cv::RNG& rng) {
  const double texel = 2 * kTexelM;
  const cv::Size size(toPx(circumference_m, texel), toPx(kPersonHeightM, texel));
  auto row = [&](double z_m) { return std::clamp(toPx(kPersonHeightM - z_m, texel), 0, size.height); };
  cv::Mat tex(size, CV_8UC3);
  // Head: skin with hair on the back half and the top.
  const cv::Scalar skin(rng.uniform(60, 160), rng.uniform(110, 190), rng.uniform(150, 235));
  const cv::Scalar hair = randomColour(rng, 0, 90);
  tex.rowRange(0, row(kBodyTopM)).setTo(skin);
  tex(cv::Rect(size.width / 4, 0, size.width / 2, row(kBodyTopM))).setTo(hair);  // back of the head
  tex.rowRange(0, row(1.64)).setTo(hair);
  // Shirt and trousers with a seeded pattern.
  cv::Mat shirt = tex.rowRange(row(kBodyTopM), row(0.85));
  cv::Mat trousers = tex.rowRange(row(0.85), row(0.08));
  shirt.setTo(randomColour(rng, 30, 230));
  trousers.setTo(randomColour(rng, 20, 140));
  tex.rowRange(row(0.08), size.height).setTo(randomColour(rng, 0, 60));  // shoes
  const int stripes = rng.uniform(0, 3);
  if (stripes > 0) {
    const int period = toPx(rng.uniform(0.04, 0.12), texel);
    const cv::Scalar c = randomColour(rng);
    for (int y = 0; y < shirt.rows; y += period) {
      cv::Rect r = stripes == 1 ? cv::Rect(0, y, shirt.cols, period / 2) : cv::Rect(y, 0, period / 2, shirt.rows);
      cv::rectangle(shirt, r & cv::Rect(0, 0, shirt.cols, shirt.rows), c, cv::FILLED);
    }
  }
  // A print on the front and back (centre of the unrolled texture = back, edges = front).
  for (int side = 0; side < 2; ++side) {
    const int cx = side == 0 ? size.width / 2 : 0;
    const cv::Rect print(cx - shirt.cols / 8, shirt.rows / 5, shirt.cols / 4, shirt.rows / 3);
    cv::Mat roi = shirt(print & cv::Rect(0, 0, shirt.cols, shirt.rows));
    if (!roi.empty()) drawBlobs(roi, rng);
  }
  return tex;
}

}  // namespace dypho::tools::synth_detail
