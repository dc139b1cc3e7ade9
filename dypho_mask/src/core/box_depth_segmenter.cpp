#include "dypho/mask/box_depth_segmenter.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "depth_layers.h"
#include "mask_internal.h"

namespace dypho {
namespace mask {
namespace {

/// [lo, hi] of the nearest depth window of `range` holding min_cluster_share of `z` (sorted).
void nearestCluster(const std::vector<float>& z, const BoxDepthSettings& s, float& lo, float& hi) {
  const size_t need = std::max<size_t>(1, static_cast<size_t>(s.min_cluster_share * z.size()));
  float d_near = z.front();
  for (size_t i = 0, j = 0; i < z.size(); ++i) {
    while (j < z.size() && z[j] <= z[i] + s.depth_range_m) ++j;
    if (j - i >= need) {
      d_near = z[i];
      break;
    }
  }
  lo = d_near - 0.1f;
  hi = d_near + static_cast<float>(s.depth_range_m);
}

/// A layer this far in front of its region's far depth is an object [m].
constexpr float kLayerInFrontM = 0.3f;

/// The components of what the layers so far left of the regions, by label: valid depths [m],
/// pixel count, the original region they lie in, and whether they reach into the eroded core.
struct RestComponents {
  std::vector<std::vector<float>> z;
  std::vector<int> total, parent;
  std::vector<bool> has_core;
};

/// RestComponents of the `n` labels of `labels`, with `regions` the original regions' labels and
/// `core` (non-zero) the part of the rest wider than the halo.
RestComponents describeRest(const cv::Mat& labels, int n, const cv::Mat& regions, const cv::Mat& depth_m,
                            const cv::Mat& core) {
  RestComponents c;
  c.z.resize(n);
  c.total.assign(n, 0);
  c.parent.assign(n, 0);
  c.has_core.assign(n, false);
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const int* r = regions.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    const uchar* k = core.ptr<uchar>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (l[x] == 0) continue;
      ++c.total[l[x]];
      c.parent[l[x]] = r[x];
      c.has_core[l[x]] = c.has_core[l[x]] || k[x] != 0;
      if (d[x] > 0.f) c.z[l[x]].push_back(d[x]);
    }
  }
  return c;
}

/// Depth window [lo, hi] of every component kept as a farther layer: its nearest cluster, when
/// the component is wider than the halo (has_core), has enough valid depths and lies more than
/// kLayerInFrontM in front of its region's far depth; an empty window (lo > hi) otherwise.
/// Returns whether any component is kept.
bool chooseLayerWindows(RestComponents& c, const BoxDepthSettings& s, const BoxDepthSettings& layer_settings,
                        const std::vector<float>& region_far, std::vector<float>& lo, std::vector<float>& hi) {
  const int n = static_cast<int>(c.z.size());
  lo.assign(n, 1.f);  // empty range: nothing kept
  hi.assign(n, -1.f);
  bool any = false;
  for (int i = 1; i < n; ++i) {
    std::vector<float>& z = c.z[i];
    if (!c.has_core[i] || z.empty() || static_cast<double>(z.size()) < s.min_valid_share * c.total[i]) continue;
    internal::sortDepths(z);
    float near_lo = 0.f, near_hi = 0.f;
    nearestCluster(z, layer_settings, near_lo, near_hi);
    if (near_hi < region_far[c.parent[i]] - kLayerInFrontM) {
      lo[i] = near_lo;
      hi[i] = near_hi;
      any = true;
    }
  }
  return any;
}

/// Sets 255 in `mask` where a labelled pixel's depth lies in its component's window.
void paintLayerWindows(const cv::Mat& labels, const cv::Mat& depth_m, const std::vector<float>& lo,
                       const std::vector<float>& hi, cv::Mat& mask) {
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    uchar* m = mask.ptr<uchar>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (l[x] != 0 && d[x] >= lo[l[x]] && d[x] <= hi[l[x]]) m[x] = 255;
    }
  }
}

}  // namespace

bool paintBoxForeground(const cv::Mat& depth_m, const cv::Rect& box_in, const BoxDepthSettings& s,
                        cv::Mat& mask_image) {
  CV_Assert(mask_image.type() == CV_8UC1);
  const cv::Rect box = box_in & cv::Rect(cv::Point(0, 0), mask_image.size());
  if (box.empty()) return false;
  cv::Mat roi = mask_image(box);
  if (depth_m.empty() || depth_m.size() != mask_image.size() || depth_m.type() != CV_32FC1) {
    roi.setTo(255);
    return false;
  }
  const cv::Mat d = depth_m(box);
  // Sample at most ~4000 depths (stride) to find the cluster; paint every pixel afterwards.
  const int stride = std::max(1, static_cast<int>(std::sqrt(box.area() / 4000.0)));
  std::vector<float> z;
  int total = 0;
  for (int y = 0; y < d.rows; y += stride) {
    const float* p = d.ptr<float>(y);
    for (int x = 0; x < d.cols; x += stride, ++total) {
      if (p[x] > 0.f) z.push_back(p[x]);  // rejects NaN too
    }
  }
  if (z.empty() || static_cast<double>(z.size()) < s.min_valid_share * total) {
    roi.setTo(255);
    return false;
  }
  internal::sortDepths(z);
  float lo = 0.f, hi = 0.f;
  nearestCluster(z, s, lo, hi);
  cv::Mat fg(box.size(), CV_8UC1);
  for (int y = 0; y < d.rows; ++y) {
    const float* p = d.ptr<float>(y);
    uchar* f = fg.ptr<uchar>(y);
    for (int x = 0; x < d.cols; ++x) f[x] = (p[x] >= lo && p[x] <= hi) ? 255 : 0;
  }
  cv::morphologyEx(fg, fg, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, {5, 5}));
  roi |= fg;
  return true;
}

void cutRegionsToDepthForeground(const cv::Mat& depth_m, const BoxDepthSettings& s, cv::Mat& mask) {
  CV_Assert(mask.type() == CV_8UC1 && depth_m.type() == CV_32FC1 && depth_m.size() == mask.size());
  cv::Mat labels;
  const int n = cv::connectedComponents(mask, labels, 8, CV_32S);
  if (n <= 1) return;
  std::vector<std::vector<float>> z(n);
  std::vector<int> total(n, 0);
  for (int y = 0; y < mask.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (l[x] == 0) continue;
      ++total[l[x]];
      if (d[x] > 0.f) z[l[x]].push_back(d[x]);
    }
  }
  std::vector<float> lo(n, -1.f), hi(n, 1e30f);
  for (int i = 1; i < n; ++i) {
    if (z[i].empty() || static_cast<double>(z[i].size()) < s.min_valid_share * total[i]) continue;
    internal::sortDepths(z[i]);
    nearestCluster(z[i], s, lo[i], hi[i]);
  }
  for (int y = 0; y < mask.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    uchar* m = mask.ptr<uchar>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (l[x] == 0 || !(d[x] > 0.f)) continue;
      if (d[x] < lo[l[x]] || d[x] > hi[l[x]]) m[x] = 0;
    }
  }
}

std::vector<float> internal::regionFarDepths(const cv::Mat& depth_m, const cv::Mat& regions, int num_regions) {
  std::vector<std::vector<float>> region_z(num_regions);
  for (int y = 0; y < regions.rows; ++y) {
    const int* l = regions.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    for (int x = 0; x < regions.cols; ++x) {
      if (l[x] != 0 && d[x] > 0.f) region_z[l[x]].push_back(d[x]);
    }
  }
  std::vector<float> region_far(num_regions, 0.f);
  for (int i = 1; i < num_regions; ++i) {
    auto& z = region_z[i];
    if (z.empty()) continue;
    const auto k = z.begin() + static_cast<std::ptrdiff_t>(0.95 * (z.size() - 1));
    std::nth_element(z.begin(), k, z.end());
    region_far[i] = *k;
  }
  return region_far;
}

void cutRegionsToDepthLayers(const cv::Mat& depth_m, const BoxDepthSettings& s, int halo_px, int max_layers,
                             cv::Mat& mask, cv::Mat* nearest_layer) {
  CV_Assert(mask.type() == CV_8UC1 && depth_m.type() == CV_32FC1 && depth_m.size() == mask.size());
  // The far depth of every original region (95th percentile): the background behind its objects.
  cv::Mat regions;
  const int num_regions = cv::connectedComponents(mask, regions, 8, CV_32S);
  if (num_regions <= 1) {
    if (nearest_layer != nullptr) mask.copyTo(*nearest_layer);
    return;
  }
  const std::vector<float> region_far = internal::regionFarDepths(depth_m, regions, num_regions);
  const cv::Mat work = mask.clone();
  cutRegionsToDepthForeground(depth_m, s, mask);  // layer 1: the nearest object of every region
  if (nearest_layer != nullptr) mask.copyTo(*nearest_layer);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * halo_px + 1, 2 * halo_px + 1));
  // What is left of a region mixes objects and background; an object may hold a small share.
  BoxDepthSettings layer_settings = s;
  layer_settings.min_cluster_share = std::min(s.min_cluster_share, 0.05);
  cv::Mat rest, core, labels;
  std::vector<float> lo, hi;
  for (int layer = 1; layer < max_layers; ++layer) {
    // What the layers so far left of the regions: objects farther back, and the halo on the
    // background. The halo is a band about as wide as the flow's margin; an object is wider.
    cv::bitwise_and(work, ~mask, rest);
    cv::erode(rest, core, kernel);
    if (cv::countNonZero(core) == 0) return;
    const int n = cv::connectedComponents(rest, labels, 8, CV_32S);
    RestComponents components = describeRest(labels, n, regions, depth_m, core);
    if (!chooseLayerWindows(components, s, layer_settings, region_far, lo, hi)) return;
    paintLayerWindows(labels, depth_m, lo, hi, mask);
  }
}

void growRegionsInDepth(const cv::Mat& depth_m, const cv::Mat& background_m, const DepthGrowSettings& g,
                        cv::Mat& mask) {
  CV_Assert(mask.type() == CV_8UC1 && depth_m.type() == CV_32FC1 && depth_m.size() == mask.size() &&
            background_m.type() == CV_32FC1 && background_m.size() == mask.size());
  cv::Mat labels;
  const int n = cv::connectedComponents(mask, labels, 8, CV_32S);
  if (n <= 1) return;
  CV_Assert(labels.isContinuous() && depth_m.isContinuous() && background_m.isContinuous() && mask.isContinuous());
  BoxDepthSettings s;
  s.depth_range_m = g.depth_range_m;
  std::vector<std::vector<float>> z(n);
  std::vector<std::size_t> area_px(n, 0);
  const int w = mask.cols, h = mask.rows;
  for (int y = 0; y < h; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      ++area_px[l[x]];
      if (l[x] != 0 && d[x] > 0.f) z[l[x]].push_back(d[x]);
    }
  }
  std::vector<float> lo(n, 1.f), hi(n, -1.f);  // empty range: regions without depth do not grow
  for (int i = 1; i < n; ++i) {
    if (z[i].empty() || static_cast<int>(z[i].size()) < g.min_seed_area_px) continue;
    internal::sortDepths(z[i]);
    nearestCluster(z[i], s, lo[i], hi[i]);
  }
  // Breadth-first growth from every region pixel that has depth in its cluster.
  std::deque<int> queue;
  for (int y = 0; y < h; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* d = depth_m.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      if (l[x] != 0 && d[x] >= lo[l[x]] && d[x] <= hi[l[x]]) queue.push_back(y * w + x);
    }
  }
  const float sigma = static_cast<float>(g.sigma_m);
  const float step0 = static_cast<float>(g.max_step_m), step_rel = static_cast<float>(g.max_step_rel);
  int* L = labels.ptr<int>(0);
  const float* D = depth_m.ptr<float>(0);
  const float* B = background_m.ptr<float>(0);
  uchar* M = mask.ptr<uchar>(0);
  // Pixels each region gained, and the regions that grew past their limit (not grown at all).
  std::vector<std::vector<int>> grown(n);
  std::vector<char> too_far(n, 0);
  const auto limit = [&](int label) {
    return g.max_growth_ratio > 0.0 ? g.max_growth_ratio * static_cast<double>(area_px[label])
                                    : std::numeric_limits<double>::infinity();
  };
  while (!queue.empty()) {
    const int i = queue.front();
    queue.pop_front();
    const int x = i % w, y = i / w, label = L[i];
    if (too_far[label]) continue;
    const float d = D[i], step = step0 + step_rel * d;
    const int neighbours[4] = {x > 0 ? i - 1 : -1, x + 1 < w ? i + 1 : -1, y > 0 ? i - w : -1, y + 1 < h ? i + w : -1};
    for (const int j : neighbours) {
      if (j < 0 || L[j] != 0) continue;
      const float dj = D[j];
      if (!(dj >= lo[label] && dj <= hi[label]) || std::abs(dj - d) > step) continue;
      if (B[j] > 0.f && dj >= B[j] - sigma) continue;  // the background explains it
      L[j] = label;
      M[j] = 255;
      queue.push_back(j);
      grown[label].push_back(j);
      if (static_cast<double>(grown[label].size()) > limit(label)) {
        too_far[label] = 1;
        break;
      }
    }
  }
  for (int label = 1; label < n; ++label) {
    if (!too_far[label]) continue;
    for (const int j : grown[label]) M[j] = 0;  // its pixels stay labelled: no other region takes them
  }
}

}  // namespace mask
}  // namespace dypho
