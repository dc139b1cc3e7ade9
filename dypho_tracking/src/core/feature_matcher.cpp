#include "dypho/tracking/feature_matcher.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <opencv2/features2d.hpp>

#include "keypoint_grid.h"

namespace dypho {
namespace tracking {
namespace {

/// Hamming distance of two 32-byte ORB descriptors [bits].
inline int hamming256(const uchar* a, const uchar* b) {
  int d = 0;
  for (int k = 0; k < 4; ++k) {
    std::uint64_t x, y;
    std::memcpy(&x, a + 8 * k, 8);
    std::memcpy(&y, b + 8 * k, 8);
    d += __builtin_popcountll(x ^ y);
  }
  return d;
}

/// Keeps, for each frame keypoint, only the match with the smallest distance.
std::vector<FeatureMatch> makeOneToOne(const std::vector<FeatureMatch>& matches, size_t frame_size) {
  std::vector<int> best(frame_size, -1);
  for (size_t m = 0; m < matches.size(); ++m) {
    int& b = best[static_cast<size_t>(matches[m].frame_index)];
    if (b < 0 || matches[m].distance < matches[static_cast<size_t>(b)].distance) {
      b = static_cast<int>(m);
    }
  }
  std::vector<FeatureMatch> out;
  for (int b : best) {
    if (b >= 0) out.push_back(matches[static_cast<size_t>(b)]);
  }
  return out;
}

}  // namespace

std::vector<FeatureMatch> filterByRotationConsistency(const std::vector<FeatureMatch>& matches,
                                                      const KeyframePoints& reference, const FrameFeatures& frame) {
  constexpr int kBins = 30;
  std::array<std::vector<int>, kBins> histogram;
  for (size_t m = 0; m < matches.size(); ++m) {
    float rot = reference.keypoints[static_cast<size_t>(matches[m].reference_index)].angle -
                frame.keypoints[static_cast<size_t>(matches[m].frame_index)].angle;
    if (rot < 0.0f) rot += 360.0f;
    int bin = static_cast<int>(std::lround(rot * kBins / 360.0f)) % kBins;
    histogram[static_cast<size_t>(bin)].push_back(static_cast<int>(m));
  }
  std::array<size_t, 3> top{{kBins, kBins, kBins}};  // bin indices, kBins = none
  const auto count = [&](size_t bin) { return bin < kBins ? histogram[bin].size() : 0u; };
  for (size_t b = 0; b < kBins; ++b) {
    const size_t c = histogram[b].size();
    if (c > count(top[0])) {
      top = {{b, top[0], top[1]}};
    } else if (c > count(top[1])) {
      top = {{top[0], b, top[1]}};
    } else if (c > count(top[2])) {
      top[2] = b;
    }
  }
  const size_t max_count = count(top[0]);
  std::vector<FeatureMatch> out;
  for (size_t k = 0; k < 3; ++k) {
    if (top[k] >= kBins) continue;
    if (k > 0 && static_cast<double>(count(top[k])) < 0.1 * static_cast<double>(max_count)) continue;
    for (int m : histogram[top[k]]) out.push_back(matches[static_cast<size_t>(m)]);
  }
  return out;
}

FeatureMatcher::FeatureMatcher(const TrackingOptions& options) : options_(options) { options_.validate(); }

std::vector<FeatureMatch> FeatureMatcher::matchByProjection(const KeyframePoints& reference, const FrameFeatures& frame,
                                                            const Eigen::Isometry3d& T_camera_world,
                                                            const Pinhole& pinhole, double radius_px,
                                                            bool ratio_same_level_only) const {
  std::vector<FeatureMatch> candidates;
  if (reference.size() == 0 || frame.size() == 0) return candidates;
  const KeypointGrid grid(frame.uv_undistorted_px, 16.0);
  for (size_t i = 0; i < reference.size(); ++i) {
    const Eigen::Vector3d p_c = T_camera_world * reference.p_world_m[i];
    if (p_c.z() < 1e-3) continue;
    const Eigen::Vector2d uv = pinhole.project(p_c);
    int level = reference.keypoints[i].octave;
    if (!reference.reference_distance_m.empty()) {
      // Scale invariance: the level the point should appear at from the current distance,
      // skipped when outside the pyramid's range (ORB-SLAM's min/max distance test).
      const double predicted =
          level + std::log(reference.reference_distance_m[i] / p_c.norm()) / std::log(options_.scale_factor);
      if (predicted < -1.0 || predicted > options_.num_levels) continue;
      level = std::clamp(static_cast<int>(std::lround(predicted)), 0, options_.num_levels - 1);
    }
    const double r = radius_px * std::pow(options_.scale_factor, level);
    const uchar* d_ref = reference.descriptors.ptr<uchar>(static_cast<int>(i));
    int best = INT_MAX, second = INT_MAX, best_index = -1, best_octave = -1, second_octave = -1;
    grid.forEachNear(uv, r, [&](int j) {
      const Eigen::Vector2d& q = frame.uv_undistorted_px[static_cast<size_t>(j)];
      if (std::abs(q.x() - uv.x()) > r || std::abs(q.y() - uv.y()) > r) return;
      const int octave = frame.keypoints[static_cast<size_t>(j)].octave;
      if (std::abs(octave - level) > options_.max_level_difference) return;
      const int d = hamming256(d_ref, frame.descriptors.ptr<uchar>(j));
      if (d < best) {
        second = best;
        second_octave = best_octave;
        best = d;
        best_index = j;
        best_octave = octave;
      } else if (d < second) {
        second = d;
        second_octave = octave;
      }
    });
    if (best_index < 0 || best > options_.max_hamming_distance) continue;
    // The relaxed test only for a point proven static (verified); a fresh point may lie on a
    // person the mask missed, and the strict test keeps its ambiguous matches out.
    const bool verified = !reference.verified.empty() && reference.verified[i] != 0;
    const bool competing = !(ratio_same_level_only && verified) || second_octave == best_octave;
    if (second != INT_MAX && competing && best >= options_.ratio_test * second) continue;
    candidates.push_back({static_cast<int>(i), best_index, best});
  }
  return filterByRotationConsistency(makeOneToOne(candidates, frame.size()), reference, frame);
}

std::vector<FeatureMatch> FeatureMatcher::matchBruteForce(const KeyframePoints& reference,
                                                          const FrameFeatures& frame) const {
  std::vector<FeatureMatch> out;
  if (reference.size() < 2 || frame.size() < 2) return out;
  cv::BFMatcher matcher(cv::NORM_HAMMING, false);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(reference.descriptors, frame.descriptors, knn, 2);
  std::vector<cv::DMatch> reverse;
  matcher.match(frame.descriptors, reference.descriptors, reverse);
  for (const auto& pair : knn) {
    if (pair.empty()) continue;
    const cv::DMatch& best = pair[0];
    if (best.distance > options_.max_hamming_distance) continue;
    if (pair.size() > 1 && best.distance >= options_.ratio_test * pair[1].distance) continue;
    if (reverse[static_cast<size_t>(best.trainIdx)].trainIdx != best.queryIdx) continue;  // mutual
    out.push_back({best.queryIdx, best.trainIdx, static_cast<int>(best.distance)});
  }
  return filterByRotationConsistency(out, reference, frame);
}

}  // namespace tracking
}  // namespace dypho
