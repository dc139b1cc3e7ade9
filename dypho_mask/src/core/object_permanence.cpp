#include "dypho/mask/object_permanence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "dypho/mask/box_depth_segmenter.h"
#include "mask_internal.h"

namespace dypho {
namespace mask {

using internal::valid;

namespace {

/// Largest depth step between 4-neighbours on one surface [m]: the depth growth's rule.
inline float surfaceStep(float z) {
  static const DepthGrowSettings grow;
  return static_cast<float>(grow.max_step_m + grow.max_step_rel * z);
}

/// Distance from a kept pixel at which its surroundings are read, in the four axis directions [px
/// at the background model's resolution].
constexpr int kOutlineOffsetPx = 3;

/// Labels the surfaces of `mask` (non-zero pixels with depth): 4-connected pixels whose depths
/// differ by at most surfaceStep() share a label (1..n); other pixels get 0. Returns n + 1.
int labelSurfaces(const cv::Mat& mask, const cv::Mat& depth_m, cv::Mat& labels, std::vector<int>& queue) {
  labels.create(mask.size(), CV_32SC1);
  labels.setTo(0);
  const int w = mask.cols, h = mask.rows;
  CV_Assert(mask.isContinuous() && depth_m.isContinuous() && labels.isContinuous());
  const uchar* M = mask.ptr<uchar>(0);
  const float* D = depth_m.ptr<float>(0);
  int* L = labels.ptr<int>(0);
  int n = 0;
  for (int start = 0; start < w * h; ++start) {
    if (M[start] == 0 || L[start] != 0 || !valid(D[start])) continue;
    L[start] = ++n;
    queue.assign(1, start);
    for (size_t head = 0; head < queue.size(); ++head) {
      const int i = queue[head], x = i % w, y = i / w;
      const float step = surfaceStep(D[i]);
      const int neighbours[4] = {x > 0 ? i - 1 : -1, x + 1 < w ? i + 1 : -1, y > 0 ? i - w : -1,
                                 y + 1 < h ? i + w : -1};
      for (const int j : neighbours) {
        if (j < 0 || M[j] == 0 || L[j] != 0 || !valid(D[j]) || std::abs(D[j] - D[i]) > step) continue;
        L[j] = n;
        queue.push_back(j);
      }
    }
  }
  return n + 1;
}

}  // namespace

ObjectPermanence::ObjectPermanence(const PermanenceSettings& settings) : settings_(settings) {
  if (settings.max_quiet_frames < 1 || settings.max_quiet_frames > 10000) {
    throw std::invalid_argument("permanence max_quiet_frames must be in [1, 10000], got " +
                                std::to_string(settings.max_quiet_frames));
  }
  for (const double share : {settings.min_background_share, settings.min_farther_outline_share}) {
    if (!(share >= 0.0 && share <= 1.0)) {
      throw std::invalid_argument(
          "permanence min_background_share and min_farther_outline_share must be in [0, 1], got " +
          std::to_string(share));
    }
  }
  if (!(settings.max_depth_change_m > 0.0) || !(settings.sigma_m > 0.0)) {
    throw std::invalid_argument("permanence max_depth_change_m and sigma_m must be > 0");
  }
}

void ObjectPermanence::reset() {
  mask_.release();
  kept_.release();
}

void ObjectPermanence::carry(const cv::Mat& flow, const cv::Mat& depth_m, const cv::Mat& background_m, cv::Mat& kept,
                             const cv::Mat& found_now) {
  CV_Assert(depth_m.type() == CV_32FC1);
  const cv::Size size = depth_m.size();
  kept.create(size, CV_8UC1);
  kept.setTo(0);
  kept_quiet_.create(size, CV_16UC1);
  kept_quiet_.setTo(0);
  const bool have_background = !background_m.empty();
  if (have_background) CV_Assert(background_m.type() == CV_32FC1 && background_m.size() == size);
  if (mask_.empty() || mask_.size() != size || flow.empty() || flow.type() != CV_32FC2) {
    kept.copyTo(kept_);
    return;
  }
  // The flow at this resolution, in this resolution's pixels (same pixel-centre convention).
  cv::resize(flow, map_, size, 0, 0, cv::INTER_LINEAR);
  const float sx = static_cast<float>(size.width) / static_cast<float>(flow.cols);
  const float sy = static_cast<float>(size.height) / static_cast<float>(flow.rows);
  for (int y = 0; y < size.height; ++y) {
    cv::Vec2f* m = map_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < size.width; ++x) m[x] = cv::Vec2f(x + m[x][0] * sx, y + m[x][1] * sy);
  }
  cv::remap(mask_, carried_mask_, map_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::remap(depth_, carried_depth_, map_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::remap(quiet_, kept_quiet_, map_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  const float max_change = static_cast<float>(settings_.max_depth_change_m);
  const float sigma = static_cast<float>(settings_.sigma_m);
  const int max_quiet = settings_.max_quiet_frames;
  for (int y = 0; y < size.height; ++y) {
    const uchar* c = carried_mask_.ptr<uchar>(y);
    const float* cd = carried_depth_.ptr<float>(y);
    const float* d = depth_m.ptr<float>(y);
    const float* b = have_background ? background_m.ptr<float>(y) : nullptr;
    const ushort* q = kept_quiet_.ptr<ushort>(y);
    uchar* k = kept.ptr<uchar>(y);
    for (int x = 0; x < size.width; ++x) {
      if (c[x] == 0 || !valid(d[x]) || !valid(cd[x])) continue;
      if (std::abs(d[x] - cd[x]) > max_change) continue;                  // another surface now
      if (b != nullptr && valid(b[x]) && d[x] >= b[x] - sigma) continue;  // the background explains it
      if (q[x] + 1 > max_quiet) continue;                                 // not seen move for too long
      k[x] = 255;
    }
  }
  if (settings_.min_farther_outline_share > 0.0) dropSurfacesInFrontOfNothing(depth_m, background_m, found_now, kept);
  kept.copyTo(kept_);
}

void ObjectPermanence::dropSurfacesInFrontOfNothing(const cv::Mat& depth_m, const cv::Mat& background_m,
                                                    const cv::Mat& found_now, cv::Mat& kept) {
  // A kept pixel with a background value stands in front of it (carry() dropped the explained
  // ones). A surface with too few of them must show in its surroundings that it stands in front
  // of something; otherwise it is a patch of wall or floor the background model has never seen,
  // which the mask once took in with a person.
  const int n = labelSurfaces(kept, depth_m, labels_, queue_);
  if (n <= 1) return;
  const auto count = static_cast<size_t>(n);
  std::vector<int> total(count, 0), with_background(count, 0), around(count, 0), farther(count, 0);
  const bool have_background = !background_m.empty();
  const bool have_found = !found_now.empty();
  if (have_found) CV_Assert(found_now.type() == CV_8UC1 && found_now.size() == kept.size());
  const float sigma = static_cast<float>(settings_.sigma_m);
  const int w = kept.cols, h = kept.rows;
  // The surroundings: valid depth, neither kept nor found dynamic now (the person's other parts).
  const auto surrounding = [&](int x, int y) {
    return x >= 0 && x < w && y >= 0 && y < h && kept.at<uchar>(y, x) == 0 &&
           (!have_found || found_now.at<uchar>(y, x) == 0) && valid(depth_m.at<float>(y, x));
  };
  constexpr int r = kOutlineOffsetPx;
  for (int y = 0; y < h; ++y) {
    const int* l = labels_.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    const float* b = have_background ? background_m.ptr<float>(y) : nullptr;
    for (int x = 0; x < w; ++x) {
      if (l[x] == 0) continue;
      const auto i = static_cast<size_t>(l[x]);
      ++total[i];
      with_background[i] += b != nullptr && valid(b[x]);
      const int xs[4] = {x - r, x + r, x, x};
      const int ys[4] = {y, y, y - r, y + r};
      for (int k = 0; k < 4; ++k) {
        if (!surrounding(xs[k], ys[k])) continue;
        ++around[i];
        farther[i] += depth_m.at<float>(ys[k], xs[k]) > d[x] + sigma;
      }
    }
  }
  std::vector<bool> drop(count, false);
  for (size_t i = 1; i < count; ++i) {
    drop[i] = with_background[i] < settings_.min_background_share * total[i] &&
              farther[i] < settings_.min_farther_outline_share * around[i];
  }
  for (int y = 0; y < h; ++y) {
    const int* l = labels_.ptr<int>(y);
    uchar* k = kept.ptr<uchar>(y);
    for (int x = 0; x < w; ++x)
      if (drop[static_cast<size_t>(l[x])]) k[x] = 0;
  }
}

void ObjectPermanence::remember(const cv::Mat& dynamic, const cv::Mat& evidence, const cv::Mat& depth_m) {
  CV_Assert(dynamic.type() == CV_8UC1 && evidence.type() == CV_8UC1 && depth_m.type() == CV_32FC1 &&
            dynamic.size() == evidence.size() && dynamic.size() == depth_m.size());
  const cv::Size size = dynamic.size();
  const bool have_kept = !kept_.empty() && kept_.size() == size;
  const int n = labelSurfaces(dynamic, depth_m, labels_, queue_);
  // Quiet count of each surface: 0 where evidence touches it, else the smallest of its kept
  // pixels' carried count + 1; a surface with neither counts as fresh.
  constexpr int kNone = std::numeric_limits<int>::max();
  std::vector<int> region_quiet(static_cast<size_t>(std::max(n, 1)), kNone);
  for (int y = 0; y < size.height; ++y) {
    const int* l = labels_.ptr<int>(y);
    const uchar* e = evidence.ptr<uchar>(y);
    const uchar* k = have_kept ? kept_.ptr<uchar>(y) : nullptr;
    const ushort* q = have_kept ? kept_quiet_.ptr<ushort>(y) : nullptr;
    for (int x = 0; x < size.width; ++x) {
      if (l[x] == 0) continue;
      int& r = region_quiet[static_cast<size_t>(l[x])];
      if (e[x] != 0) {
        r = 0;
      } else if (k != nullptr && k[x] != 0) {
        r = std::min(r, q[x] + 1);
      }
    }
  }
  quiet_.create(size, CV_16UC1);
  mask_.create(size, CV_8UC1);
  for (int y = 0; y < size.height; ++y) {
    const int* l = labels_.ptr<int>(y);
    ushort* q = quiet_.ptr<ushort>(y);
    uchar* m = mask_.ptr<uchar>(y);
    for (int x = 0; x < size.width; ++x) {
      const int r = l[x] == 0 ? 0 : region_quiet[static_cast<size_t>(l[x])];
      m[x] = l[x] == 0 ? 0 : 255;
      q[x] = static_cast<ushort>(r == kNone ? 0 : std::min(r, 65535));
    }
  }
  depth_m.copyTo(depth_);
  kept_.release();
}

}  // namespace mask
}  // namespace dypho
