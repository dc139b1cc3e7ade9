// Report-style checks of the flow mask and the whole dynamic mask on the real sequences in
// DYPHO_SHARED_DIR/data (skipped, loudly, when the data is absent). Prints masked fractions;
// asserts only coarse properties.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "dypho/common/motion_prior.h"
#include "dypho/mask/dynamic_masker.h"
#include "dypho/mask/flow_motion_masker.h"

namespace dypho {
namespace mask {
namespace DYPHO_UNITY_ID {

/// Stamps [s] and paths of a TUM-format list ("timestamp path" lines, '#' comments).
std::vector<std::pair<double, std::string>> listStamped(const std::string& folder, const std::string& list) {
  std::vector<std::pair<double, std::string>> entries;
  std::ifstream in(folder + "/" + list);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double stamp = 0.0;
    std::string path;
    if (s >> stamp >> path) entries.emplace_back(stamp, folder + "/" + path);
  }
  return entries;
}

/// Image paths listed in a TUM-format rgb.txt.
std::vector<std::string> listImages(const std::string& folder) {
  std::vector<std::string> paths;
  for (const auto& entry : listStamped(folder, "rgb.txt")) paths.push_back(entry.second);
  return paths;
}

struct RangeStats {
  double mean_fraction = 0.0;
  double max_fraction = 0.0;
  int degraded = 0;
  int frames = 0;
  double mean_total_ms = 0.0;
};

/// Runs the masker on images [first, last] (the first of them only primes the history).
RangeStats runRange(const std::vector<std::string>& paths, int first, int last) {
  FlowMotionMasker masker{FlowMaskOptions()};
  RangeStats st;
  for (int i = first; i <= last && i < static_cast<int>(paths.size()); ++i) {
    RgbdFrame f;
    f.bgr = cv::imread(paths[static_cast<std::size_t>(i)], cv::IMREAD_COLOR);
    EXPECT_FALSE(f.bgr.empty()) << "cannot read " << paths[static_cast<std::size_t>(i)];
    const FlowMaskResult r = masker.compute(f);
    if (i == first) continue;
    ++st.frames;
    st.degraded += r.degraded ? 1 : 0;
    st.mean_fraction += r.masked_fraction;
    st.max_fraction = std::max(st.max_fraction, r.masked_fraction);
    st.mean_total_ms += r.total_ms;
  }
  if (st.frames > 0) {
    st.mean_fraction /= st.frames;
    st.mean_total_ms /= st.frames;
  }
  return st;
}

void print(const char* label, const RangeStats& s) {
  std::printf("[ report ] %-44s frames %3d  masked mean %.4f max %.4f  degraded %d  %.2f ms\n", label, s.frames,
              s.mean_fraction, s.max_fraction, s.degraded, s.mean_total_ms);
}

TEST(FlowMaskRealData, BonnCrowdPeopleVersusEmptyRoom) {
  const std::string folder = std::string(DYPHO_SHARED_DIR) + "/data/rgbd_bonn_crowd_frames200to399";
  const auto paths = listImages(folder);
  if (paths.size() < 120) GTEST_SKIP() << "Bonn crowd data not found in " << folder;
  // SOURCE.txt says people enter at about index 35; looking at the images, one person already
  // walks in at the left edge from about index 19. So 0-18 is the truly empty room.
  const RangeStats empty_room = runRange(paths, 0, 18);
  const RangeStats first_30 = runRange(paths, 0, 29);
  const RangeStats people_a = runRange(paths, 60, 90);
  const RangeStats people_b = runRange(paths, 120, 150);
  print("bonn crowd, empty room (idx 0-18)", empty_room);
  print("bonn crowd, first 30 (person enters ~19)", first_30);
  print("bonn crowd, people (idx 60-90)", people_a);
  print("bonn crowd, people (idx 120-150)", people_b);
  // Coarse sanity: with people walking, far more of the image is masked than in the empty room,
  // in both stretches with people; and more once the first person has entered (from ~19).
  EXPECT_GT(people_a.mean_fraction, 3.0 * empty_room.mean_fraction);
  EXPECT_GT(people_b.mean_fraction, 3.0 * empty_room.mean_fraction);
  EXPECT_GT(first_30.mean_fraction, empty_room.mean_fraction);
  EXPECT_GT(first_30.max_fraction, empty_room.max_fraction);
  // In the empty room every masked pixel is a false positive; the camera moves slowly there, so
  // on average less than 5 % of the image may be masked.
  EXPECT_LT(empty_room.mean_fraction, 0.05);
}

TEST(FlowMaskRealData, TumRpyStaticSceneRotatingCamera) {
  const std::string folder = std::string(DYPHO_SHARED_DIR) + "/data/tum_fr1_rpy_first150";
  const auto paths = listImages(folder);
  if (paths.size() < 100) GTEST_SKIP() << "TUM fr1/rpy data not found in " << folder;
  // Static scene, mostly rotating hand-held camera: every masked pixel is a false positive.
  const RangeStats s = runRange(paths, 0, 149);
  print("tum fr1/rpy static scene (idx 0-149)", s);
  // fr1/rpy has fast rotations with strong motion blur, which break the flow in places. Without
  // the texture gate about 20 % of this static scene was masked on average; the bound of 10 %
  // guards that regression (not a target).
  EXPECT_LT(s.mean_fraction, 0.10);
}

/// Ground-truth camera poses of a TUM folder by stamp [s] (groundtruth.txt: t x y z qx qy qz qw).
std::map<double, Eigen::Isometry3d> readGroundTruth(const std::string& folder) {
  std::map<double, Eigen::Isometry3d> poses;
  std::ifstream in(folder + "/groundtruth.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(s >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) continue;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    T.translation() << x, y, z;
    poses[t] = T;
  }
  return poses;
}

/// The entry of `entries` nearest in time to `stamp_s`.
const std::string& nearest(const std::vector<std::pair<double, std::string>>& entries, double stamp_s) {
  const auto best = std::min_element(entries.begin(), entries.end(), [&](const auto& a, const auto& b) {
    return std::abs(a.first - stamp_s) < std::abs(b.first - stamp_s);
  });
  return best->second;
}

/// Masked fractions of the whole dynamic mask on a static scene (every masked pixel is a false
/// positive) and of its depth-consistency part alone, over frames 1..frames-1.
struct StaticSceneMask {
  double mean = 0.0, max = 0.0;
  double consistency_mean = 0.0, consistency_max = 0.0;
  bool found = false;           ///< false: the data is absent
  double after_gap_mean = 0.0;  ///< mean masked fraction of the 20 frames from the gap on
};

/// Frames left out of a run, as a loaded live graph drops them; the frame after them gets the
/// constant-velocity prediction across the gap from the last two true poses before it.
struct Gap {
  std::size_t first = 0;   ///< first missing frame
  std::size_t frames = 0;  ///< how many are missing (0: none)
  bool told = true;        ///< MaskPrior::after_gap set on the frame after it
};

/// Runs DynamicMasker with `options` on the first `frames` frames of TUM fr1/rpy (a static desk
/// under fast hand-held turns): every masked pixel is a false positive. The relative pose handed
/// to the masker comes from the ground truth: with `prediction_age_frames` 0 the true one (what
/// tracking hands over at best); with k >= 1 the constant-velocity prediction from the two poses
/// k frames earlier (a live graph's mask runs ahead of tracking); with -1 none (a start, a loss).
/// With `gap`, frames from `start` on, those of the gap left out (mean and max over the frames fed).
StaticSceneMask maskFr1Rpy(const DynamicMaskOptions& options, std::size_t frames, int prediction_age_frames = 0,
                           std::size_t start = 0, const Gap& gap = Gap()) {
  StaticSceneMask out;
  const std::string folder = std::string(DYPHO_SHARED_DIR) + "/data/tum_fr1_rpy_first150";
  const auto colour = listStamped(folder, "rgb.txt");
  const auto depth = listStamped(folder, "depth.txt");
  const auto truth = readGroundTruth(folder);
  if (colour.size() < frames || depth.size() < frames || truth.empty()) return out;
  out.found = true;
  const auto poseAt = [&](double stamp_s) {
    auto it = truth.lower_bound(stamp_s);
    if (it == truth.end()) --it;
    return it->second;
  };
  CameraIntrinsics camera;  // config/cameras/tum_fr1.yaml
  camera.fx = 517.306408;
  camera.fy = 516.469215;
  camera.cx = 318.643040;
  camera.cy = 255.313989;
  camera.width = 640;
  camera.height = 480;
  camera.distortion = {0.262383, -0.953104, -0.005358, 0.002628, 1.163314};
  DynamicMasker masker(options);
  ConstantVelocityModel motion;  // the true poses of the frames fed, for the prediction across the gap
  std::size_t fed = 0, after_gap = 0;
  for (std::size_t i = start; i < frames; ++i) {
    if (i >= gap.first && i < gap.first + gap.frames) continue;
    RgbdFrame frame;
    frame.stamp_ns = static_cast<Timestamp>(colour[i].first * 1e9);
    frame.bgr = cv::imread(colour[i].second, cv::IMREAD_COLOR);
    const cv::Mat raw = cv::imread(nearest(depth, colour[i].first), cv::IMREAD_UNCHANGED);
    EXPECT_FALSE(frame.bgr.empty() || raw.empty()) << "cannot read frame " << i;
    if (frame.bgr.empty() || raw.empty()) return out;
    raw.convertTo(frame.depth_m, CV_32F, 1.0 / 5000.0);
    frame.camera = camera;
    MaskPrior prior;
    const int age = prediction_age_frames;
    const bool first_after_gap = gap.frames > 0 && i == gap.first + gap.frames;
    if (first_after_gap) {
      prior.T_prev_cur = motion.last()->inverse() * *motion.predict(frame.stamp_ns);
      prior.after_gap = gap.told;
    } else if (age >= 0 && i > start + static_cast<std::size_t>(age)) {
      prior.T_prev_cur = poseAt(colour[i - 1 - age].first).inverse() * poseAt(colour[i - age].first);
      prior.prediction_fresh = age == 0;
      prior.pose_frames_behind = std::max(age - 1, 0);  // age 1: a constant-velocity prediction from fresh poses
    }
    motion.observe({frame.stamp_ns, poseAt(colour[i].first), /*trusted=*/true, /*discontinuous=*/false});
    const MaskResult result = masker.compute(frame, prior);
    if (i == start) continue;
    ++fed;
    if (gap.frames > 0 && i >= gap.first + gap.frames && after_gap < 20) {
      out.after_gap_mean += result.masked_fraction;
      ++after_gap;
    }
    const double consistency =
        result.consistency_mask.empty()
            ? 0.0
            : static_cast<double>(cv::countNonZero(result.consistency_mask)) / result.consistency_mask.total();
    out.mean += result.masked_fraction;
    out.max = std::max(out.max, result.masked_fraction);
    out.consistency_mean += consistency;
    out.consistency_max = std::max(out.consistency_max, consistency);
  }
  out.mean /= static_cast<double>(fed);
  out.consistency_mean /= static_cast<double>(fed);
  if (after_gap > 0) out.after_gap_mean /= static_cast<double>(after_gap);
  std::printf(
      "[ report ] tum fr1/rpy static desk, frames %zu-%zu (%zu fed): mask mean %.4f max %.4f, consistency mean %.4f "
      "max %.4f, 20 frames after the gap %.4f\n",
      start + 1, frames - 1, fed, out.mean, out.max, out.consistency_mean, out.consistency_max, out.after_gap_mean);
  return out;
}

TEST(DynamicMaskRealData, TumRpyStaticDeskIsNotMaskedOnTheFirstFastTurns) {
  // fr1/rpy turns fast from its first frame (up to 4 deg per frame) over a static desk. On the
  // first frames the background model has no value yet; without a growth limit a flow region of
  // a few per cent on the desk grew over the whole depth-connected desk and stayed there while
  // nothing was learnt under it: 25-58 % of the static view was masked on frames 1-13 (at 1x the
  // mask ran away to 80 %). With background_grow_max_ratio 8 and the ground-truth relative pose
  // as the prediction (what tracking hands over at best), the mask stays under 10 % on each of
  // the first 40 frames (measured: at most 9.6 %, mean 2.7 %; mean 1.6 % with
  // background_motion_tolerance, see the next test). Bounds: 20 % on any frame, 8 % on
  // average (every masked pixel of this scene is a false positive).
  const DynamicMaskOptions options;  // the defaults: background_grow_max_ratio 8
  ASSERT_EQ(options.background.grow_max_ratio, 8.0);
  const StaticSceneMask mask = maskFr1Rpy(options, 40);
  if (!mask.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  EXPECT_LE(mask.mean, 0.08);
  EXPECT_LE(mask.max, 0.20) << "on the worst frame";
}

TEST(DynamicMaskRealData, TumRpyFirstFastTurnsWithPosesThreeFramesOld) {
  // The first 40 frames of fr1/rpy with the prediction a live graph's mask gets (poses 3 frames
  // old): the relative pose is fitted to the flow (flow_fit_rigid_motion). Short enough to run
  // under the sanitizers (the 150-frame comparison is TumRpyStaticDeskNeedsNoFreshPose).
  // Measured: the whole mask 3.3 -> 2.4 % of the view, its background part 0.9 -> 0.4 %. Bounds
  // (every masked pixel is a false positive): as for the true pose above, mean at most 8 % and at
  // most 20 % on the worst frame; the background part at most 0.6 of the unfitted one.
  DynamicMaskOptions unfitted;
  unfitted.flow.fit_rigid_motion = false;
  const StaticSceneMask before = maskFr1Rpy(unfitted, 40, 3);
  if (!before.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  const StaticSceneMask mask = maskFr1Rpy(DynamicMaskOptions(), 40, 3);
  EXPECT_LE(mask.mean, 0.08);
  EXPECT_LE(mask.max, 0.20) << "on the worst frame";
  EXPECT_LE(mask.consistency_mean, 0.6 * before.consistency_mean);
}

TEST(DynamicMaskRealData, TumRpyDeskEdgesStayBehindTheBackgroundOnFastTurns) {
  // On fr1/rpy's fast turns (up to 37 px of median flow per frame) the carried background puts the
  // desk's and the furniture's depth edges a few pixels off, and the static surface in front of
  // each edge was "in front of the background": with the paper's per-pixel test the consistency
  // mask alone held 2.5 % of the static view on average over the 150 frames (12.8 % on the worst
  // frame), with the ground-truth pose; the whole mask 3.5 %. With the tolerance
  // (background_motion_tolerance 0.25 of the median flow): 1.1 % (8.4 %) and 2.3 %. With B
  // warped with the motion fitted to the flow from the true pose (background_warp_with_flow_fit,
  // the default) both are lower: 1.40 % -> 0.47 % and 2.00 % -> 1.31 %. Bounds, with room for
  // another machine's flow: the tolerance removes at least 40 % of the consistency mask and 20 %
  // of the whole mask (measured 66 % and 35 %); every masked pixel here is a false positive.
  DynamicMaskOptions per_pixel;
  per_pixel.background.motion_tolerance = 0.0;
  const DynamicMaskOptions tolerant;  // the defaults
  ASSERT_GT(tolerant.background.motion_tolerance, 0.0);
  const StaticSceneMask off = maskFr1Rpy(per_pixel, 150);
  if (!off.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  const StaticSceneMask on = maskFr1Rpy(tolerant, 150);
  EXPECT_LE(off.max, 0.20) << "on the worst frame";
  EXPECT_LE(on.max, 0.20) << "on the worst frame";
  EXPECT_LE(on.consistency_mean, 0.6 * off.consistency_mean);
  EXPECT_LE(on.mean, 0.8 * off.mean);
}

TEST(DynamicMaskRealData, TumRpyStaticDeskNeedsNoFreshPose) {
  // The mask of a live graph runs ahead of tracking: the relative pose it gets is predicted from
  // poses a few frames old. With fr1/rpy's jerky hand-held turns the prediction 3 frames old put
  // the background's depth edges off and the static desk failed the consistency test: 11.4 % of
  // the view masked on average (with the true pose 2.3 %). Fitted to the flow and the depth
  // (flow_fit_rigid_motion): 2.0 %. Bounds, with room for another machine's flow: at most 4 %
  // (every masked pixel is a false positive here) and at most half of the unfitted mask.
  DynamicMaskOptions unfitted;
  unfitted.flow.fit_rigid_motion = false;
  const DynamicMaskOptions fitted;  // the defaults
  ASSERT_TRUE(fitted.flow.fit_rigid_motion);
  const StaticSceneMask old_unfitted = maskFr1Rpy(unfitted, 150, 3);
  if (!old_unfitted.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  const StaticSceneMask old_fitted = maskFr1Rpy(fitted, 150, 3);
  EXPECT_LE(old_fitted.mean, 0.04);
  EXPECT_LE(old_fitted.mean, 0.5 * old_unfitted.mean);
}

TEST(DynamicMaskRealData, TumRpyBackgroundIsNotCarriedAcrossAGapTheFlowCannotFollow) {
  // Ten frames missing in one of fr1/rpy's fast turns (frames 45-54, as a loaded graph drops
  // them): the camera turns 17 deg across the gap, the constant-velocity prediction from the
  // poses before it 9 deg. The flow cannot follow either. Warped with the prediction, B put the
  // static desk's depth off and the mask held 55-65 % of the view for twenty frames in the whole
  // system (docs/journal/benchmarks-2026.md section 30); told of the gap (MaskPrior::after_gap),
  // the masker sees B fail on most of the view and starts B again. Frames 30-75, 36 of them fed.
  // Bounds: the twenty frames after the gap at most 5 % masked on average (every masked pixel
  // is a false positive) and at most a third of what the masker left uninformed masks.
  const Gap gap{45, 10, true};
  const StaticSceneMask told = maskFr1Rpy(DynamicMaskOptions(), 76, 0, 30, gap);
  if (!told.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  const StaticSceneMask uninformed = maskFr1Rpy(DynamicMaskOptions(), 76, 0, 30, Gap{45, 10, false});
  EXPECT_LE(told.after_gap_mean, 0.05);
  EXPECT_LE(told.after_gap_mean, uninformed.after_gap_mean / 3.0);
}

TEST(DynamicMaskRealData, TumRpyPredictionTwoFramesOldKeptForTheFlow) {
  // The live graph's mask, when tracking is slower than its wait for the previous pose, gets a
  // prediction made from the poses before the previous frame: the true relative pose of two
  // frames earlier (prediction age 2). With the flow's ego-motion taken from the prediction (its
  // homography absorbs the rotation error) and only the background warped with the fit
  // (stale_prediction_kept_frames_behind 1, the default: the newest pose is one frame before the
  // previous frame) the static desk of fr1/rpy's 150 frames is masked less than with the fit for
  // both (0, the rule before; docs/journal/benchmarks-2026.md sections 46-47): measured 1.19 %
  // against 1.87 % of the view. Bound, with room for another machine's flow: at most 0.8 of the
  // fit for both (every masked pixel is a false positive).
  const DynamicMaskOptions fit_for_background;  // the defaults
  ASSERT_EQ(fit_for_background.flow.stale_prediction_kept_frames_behind, 1);
  DynamicMaskOptions fit_for_both;
  fit_for_both.flow.stale_prediction_kept_frames_behind = 0;
  const StaticSceneMask both = maskFr1Rpy(fit_for_both, 150, 2);
  if (!both.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  const StaticSceneMask background = maskFr1Rpy(fit_for_background, 150, 2);
  EXPECT_LE(background.mean, 0.8 * both.mean);
}

TEST(DynamicMaskRealData, PredictionOlderThanKeptTakesTheFitForBoth) {
  // stale_prediction_kept_frames_behind 1 keeps only a prediction whose newest pose is one frame
  // before the previous frame; one from two frames before (prediction age 3 here) takes the fit
  // for both, as with 0: the masks must be the same (the masker is deterministic on the same
  // input; 40 frames cover fr1/rpy's first fast turns).
  DynamicMaskOptions fit_for_both;
  fit_for_both.flow.stale_prediction_kept_frames_behind = 0;
  const DynamicMaskOptions kept_one;  // the defaults
  ASSERT_EQ(kept_one.flow.stale_prediction_kept_frames_behind, 1);
  const StaticSceneMask both = maskFr1Rpy(fit_for_both, 40, 3);
  if (!both.found) GTEST_SKIP() << "TUM fr1/rpy data not found in " << DYPHO_SHARED_DIR << "/data";
  const StaticSceneMask kept = maskFr1Rpy(kept_one, 40, 3);
  EXPECT_EQ(kept.mean, both.mean);
  EXPECT_EQ(kept.max, both.max);
  DynamicMaskOptions kept_two = kept_one;  // and a bound that keeps it takes the fresh way
  kept_two.flow.stale_prediction_kept_frames_behind = 2;
  EXPECT_NE(maskFr1Rpy(kept_two, 40, 3).mean, both.mean);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mask
}  // namespace dypho
