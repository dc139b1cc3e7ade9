#include <gtest/gtest.h>

#include "dypho/tracking/feature_matcher.h"
#include "dypho/tracking/frame_features.h"
#include "dypho/tracking/keyframe_points.h"
#include "dypho/tracking/orb_extractor.h"
#include "synthetic_scene.h"

namespace dypho {
namespace tracking {
namespace DYPHO_UNITY_ID {

constexpr double kDepthM = 2.0;
constexpr int kShiftU = 14, kShiftV = -9;  // content motion between the two images [px]

struct Pair {
  KeyframePoints reference;
  FrameFeatures frame;
};

Pair makePair(OrbExtractor& extractor) {
  const TrackingOptions o;
  const cv::Mat img0 = test::texturedImage(11);
  const cv::Mat img1 = test::shifted(img0, kShiftU, kShiftV);
  const RgbdFrame f0 = test::planarFrame(img0, kDepthM, 1);
  const RgbdFrame f1 = test::planarFrame(img1, kDepthM, 2);
  const FrameFeatures ff0 =
      makeFrameFeatures(extractor.extract(img0, cv::Mat()), f0.depth_m, f0.camera, o.min_depth_m, o.max_depth_m);
  Pair p;
  p.frame = makeFrameFeatures(extractor.extract(img1, cv::Mat()), f1.depth_m, f1.camera, o.min_depth_m, o.max_depth_m);
  std::int64_t next_id = 0;
  p.reference = makeKeyframePoints(0, f0, cv::Mat(), Eigen::Isometry3d::Identity(), ff0, nullptr, {}, &next_id);
  EXPECT_EQ(next_id, static_cast<std::int64_t>(ff0.size()));  // one new id per point
  return p;
}

/// Fraction of matches whose frame keypoint lies within 1.5 px of reference + shift (FAST
/// positions are integers per level, so level > 0 points can be off by up to ~scale/2 px).
double correctFraction(const Pair& p, const std::vector<FeatureMatch>& matches) {
  int correct = 0;
  for (const auto& m : matches) {
    const auto& a = p.reference.keypoints[static_cast<size_t>(m.reference_index)].pt;
    const auto& b = p.frame.keypoints[static_cast<size_t>(m.frame_index)].pt;
    const double level_scale = std::pow(1.2, p.frame.keypoints[static_cast<size_t>(m.frame_index)].octave);
    if (std::hypot(b.x - a.x - kShiftU, b.y - a.y - kShiftV) <= 1.5 * level_scale) ++correct;
  }
  return matches.empty() ? 0.0 : static_cast<double>(correct) / matches.size();
}

TEST(FeatureMatcher, BruteForceMatchesAreMostlyCorrectAndOneToOne) {
  OrbExtractor extractor{TrackingOptions()};
  const Pair p = makePair(extractor);
  const FeatureMatcher matcher{TrackingOptions()};
  const auto matches = matcher.matchBruteForce(p.reference, p.frame);
  EXPECT_GT(matches.size(), 300u);
  // Ratio + mutual + rotation checks: at least 95 % correct on this pure translation.
  EXPECT_GT(correctFraction(p, matches), 0.95);
  std::vector<int> used(p.frame.size(), 0);
  for (const auto& m : matches) EXPECT_EQ(used[static_cast<size_t>(m.frame_index)]++, 0);
}

TEST(FeatureMatcher, ProjectionSearchUsesThePrediction) {
  OrbExtractor extractor{TrackingOptions()};
  const Pair p = makePair(extractor);
  const FeatureMatcher matcher{TrackingOptions()};
  const Pinhole k = Pinhole::fromIntrinsics(test::testCamera());
  // Camera motion that moves the content by (+14, -9) px on a wall 2 m away.
  Eigen::Isometry3d T_cw = Eigen::Isometry3d::Identity();
  T_cw.translation() = Eigen::Vector3d(kShiftU * kDepthM / k.fx, kShiftV * kDepthM / k.fy, 0);
  const auto good = matcher.matchByProjection(p.reference, p.frame, T_cw, k, 4.0);
  EXPECT_GT(good.size(), 500u);
  EXPECT_GT(correctFraction(p, good), 0.97);
  // With a wrong prediction (identity, 17 px off) and a 4 px window almost nothing is found.
  const auto bad = matcher.matchByProjection(p.reference, p.frame, Eigen::Isometry3d::Identity(), k, 4.0);
  EXPECT_LT(bad.size(), good.size() / 4);
}

/// One reference point 2 m ahead and two frame keypoints at its projection, `offset_px` apart,
/// at pyramid levels `level_a` and `level_b`, whose descriptors differ from the point's by 10 and
/// 12 bits: a is the best candidate and b the second, 10 >= 0.8 * 12 fails the ratio test.
Pair twoCandidates(int level_a, int level_b, double offset_px, const Pinhole& k) {
  cv::RNG rng(7);
  cv::Mat d(1, 32, CV_8UC1);
  rng.fill(d, cv::RNG::UNIFORM, 0, 256);
  const auto flipped = [&](int first_bit, int bits) {
    cv::Mat out = d.clone();
    for (int b = first_bit; b < first_bit + bits; ++b) out.at<uchar>(0, b / 8) ^= static_cast<uchar>(1u << (b % 8));
    return out;
  };
  Pair p;
  p.reference.p_world_m.push_back(Eigen::Vector3d(0.1, -0.05, kDepthM));
  p.reference.keypoints.emplace_back(cv::Point2f(0, 0), 31.0f, 0.0f, 0.0f, 0);
  p.reference.descriptors = d;
  p.reference.map_point_ids.push_back(0);
  p.reference.verified.push_back(1);  // a point that carries the pose
  const Eigen::Vector2d uv = k.project(p.reference.p_world_m[0]);
  const Eigen::Vector2d uvs[2] = {uv, uv + Eigen::Vector2d(offset_px, 0.0)};
  const int levels[2] = {level_a, level_b};
  for (int c = 0; c < 2; ++c) {
    p.frame.keypoints.emplace_back(cv::Point2f(uvs[c].x(), uvs[c].y()), 31.0f, 0.0f, 0.0f, levels[c]);
    p.frame.uv_undistorted_px.push_back(uvs[c]);
    p.frame.depth_m.push_back(static_cast<float>(kDepthM));
    p.frame.p_camera_m.push_back(p.reference.p_world_m[0]);
  }
  cv::vconcat(flipped(0, 10), flipped(100, 12), p.frame.descriptors);
  return p;
}

TEST(FeatureMatcher, TheSameCornerAtTheNextLevelIsNoAmbiguityForAVerifiedPointWhenAsked) {
  const FeatureMatcher matcher{TrackingOptions()};
  const Pinhole k = Pinhole::fromIntrinsics(test::testCamera());
  const Eigen::Isometry3d T_cw = Eigen::Isometry3d::Identity();
  // The corner found at levels 1 and 0: the strict test rejects it, the same-level test keeps the
  // best (level 1, 10 bits).
  const Pair same_corner = twoCandidates(1, 0, 0.5, k);
  EXPECT_TRUE(matcher.matchByProjection(same_corner.reference, same_corner.frame, T_cw, k, 4.0).empty());
  const auto kept = matcher.matchByProjection(same_corner.reference, same_corner.frame, T_cw, k, 4.0, true);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].frame_index, 0);
  EXPECT_EQ(kept[0].distance, 10);
  // A point on probation (it may lie on a person the mask missed), or one of a reference without
  // probation, keeps the strict test.
  Pair on_probation = twoCandidates(1, 0, 0.5, k);
  on_probation.reference.verified[0] = 0;
  EXPECT_TRUE(matcher.matchByProjection(on_probation.reference, on_probation.frame, T_cw, k, 4.0, true).empty());
  on_probation.reference.verified.clear();
  EXPECT_TRUE(matcher.matchByProjection(on_probation.reference, on_probation.frame, T_cw, k, 4.0, true).empty());
  // Two corners 3 px apart at the same level are an ambiguity either way.
  const Pair two_corners = twoCandidates(0, 0, 3.0, k);
  EXPECT_TRUE(matcher.matchByProjection(two_corners.reference, two_corners.frame, T_cw, k, 4.0).empty());
  EXPECT_TRUE(matcher.matchByProjection(two_corners.reference, two_corners.frame, T_cw, k, 4.0, true).empty());
  // A clear best (10 bits against the inverted 244) passes.
  Pair clear = twoCandidates(0, 0, 3.0, k);
  cv::bitwise_not(clear.frame.descriptors.row(1), clear.frame.descriptors.row(1));
  EXPECT_EQ(matcher.matchByProjection(clear.reference, clear.frame, T_cw, k, 4.0).size(), 1u);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace tracking
}  // namespace dypho
