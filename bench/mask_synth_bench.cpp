/// mask_synth_bench: accuracy and speed of the dynamic mask on synthetic sequences with
/// ground-truth masks and poses (dypho::tools::SyntheticScene).
///
///   mask_synth_bench [--motion halfsphere|xyz|static|rpy] [--frames N] [--people K] [--seed S]
///                    [--pose cv|gt|none] [--model ONNX] [--every-n N] [--async] [--threads T]
///                    [--no-background] [--no-grow] [--no-aperture] [--margin PX] [--dump DIR] [--verbose]
///
/// --pose cv: T_prev_cur predicted with constant velocity from the two previous ground-truth
/// poses (what tracking hands over); gt: the true relative pose; none: homography fallback.
/// Prints pooled IoU of the dynamic mask (sum |M & G| / sum |M | G| over frames 2..N-1), the
/// false-dynamic share (sum |M & !G| / sum |!G|), the missed share of dynamic pixels, and the
/// --dump DIR writes frame 2 and every 10th frame: mask_I.png (B = mask, G = ground truth, R = raw flow) and
/// cons_I.png (B = consistency mask, G = ground truth, R = mask); --verbose prints per-frame counts.
/// median / p90 time per frame for the flow + background part (wall time: compute() minus the
/// network part) and for the network part.

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dypho/mask/dynamic_masker.h"
#include "dypho/tools/synthetic_scene.h"
#include "help_flag.h"

using namespace dypho;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: mask_synth_bench [--motion halfsphere|xyz|static|rpy] [--frames N] [--people K] [--seed S]\n"
    "                        [--pose cv|gt|none] [--model ONNX] [--every-n N] [--async] [--threads T]\n"
    "                        [--no-background] [--no-grow] [--no-aperture] [--margin PX] [--dump DIR] [--verbose]\n"
    "Accuracy (IoU, false-dynamic and missed shares) and speed of the dynamic mask on a synthetic\n"
    "sequence with ground-truth masks and poses. Defaults: 150 frames, 2 people, seed 3, --pose cv.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  tools::SynthOptions so;
  so.frames = 150;
  so.people = 2;
  so.seed = 3;
  std::string pose = "cv", dump;
  int threads = 2;
  bool verbose = false;
  mask::DynamicMaskOptions mo;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << k << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (k == "--motion")
      so.motion = tools::parseSynthMotion(value());
    else if (k == "--frames")
      so.frames = std::stoi(value());
    else if (k == "--people")
      so.people = std::stoi(value());
    else if (k == "--seed")
      so.seed = static_cast<std::uint32_t>(std::stoul(value()));
    else if (k == "--pose")
      pose = value();
    else if (k == "--model")
      mo.yolo.model_path = value();
    else if (k == "--every-n")
      mo.yolo.every_n_frames = std::stoi(value());
    else if (k == "--async")
      mo.yolo.async = true;
    else if (k == "--threads")
      threads = std::stoi(value());
    else if (k == "--no-background")
      mo.background.enabled = false;
    else if (k == "--no-grow")
      mo.background.grow_in_depth = false;
    else if (k == "--no-aperture")
      mo.flow.aperture_aware = false;
    else if (k == "--margin")
      mo.margin_px = std::stoi(value());
    else if (k == "--dump")
      dump = value();
    else if (k == "--verbose")
      verbose = true;
    else {
      std::cerr << "unknown argument " << k << " (see the file comment)\n";
      return 2;
    }
  }
  if (pose != "cv" && pose != "gt" && pose != "none") {
    std::cerr << "--pose cv|gt|none\n";
    return 2;
  }
  cv::setNumThreads(threads);
  const tools::SyntheticScene scene(so);
  mask::DynamicMasker masker(mo);
  std::cout << "synthetic " << so.toString() << "\npose " << pose << ", threads " << threads
            << ", network: " << masker.segmentStatus() << "\n";

  double inter = 0, uni = 0, false_dyn = 0, static_px = 0, missed = 0, dyn_px = 0;
  std::vector<double> flow_bg_ms, seg_ms, total_ms, flow_ms, bg_ms;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < so.frames; ++i) {
    const tools::SynthFrame f = scene.render(i);
    poses.push_back(f.T_world_camera);
    mask::MaskPrior prior;
    if (pose == "gt" && i >= 1) prior.T_prev_cur = poses[i - 1].inverse() * poses[i];
    if (pose == "cv" && i >= 2) prior.T_prev_cur = poses[i - 2].inverse() * poses[i - 1];
    const mask::MaskResult r = masker.compute(f.frame, prior);
    if (i < 2) continue;                              // no flow yet / no constant-velocity prediction yet
    flow_bg_ms.push_back(r.total_ms - r.segment_ms);  // wall time: the background test runs beside the flow
    seg_ms.push_back(r.segment_ms);
    flow_ms.push_back(r.flow_ms);
    bg_ms.push_back(r.background_ms);
    total_ms.push_back(r.total_ms);
    const cv::Mat gt = f.mask_gt > 0, m = r.mask > 0;
    inter += cv::countNonZero(gt & m);
    uni += cv::countNonZero(gt | m);
    false_dyn += cv::countNonZero(m & ~gt);
    static_px += cv::countNonZero(~gt);
    missed += cv::countNonZero(gt & ~m);
    dyn_px += cv::countNonZero(gt);
    if (!dump.empty() && (i % 10 == 0 || i == 2)) {
      cv::Mat vis;
      cv::Mat ch[3] = {r.mask, f.mask_gt,
                       r.raw_flow_mask.empty() ? cv::Mat::zeros(gt.size(), CV_8UC1) : r.raw_flow_mask};
      cv::merge(ch, 3, vis);
      cv::imwrite(dump + "/mask_" + std::to_string(i) + ".png", vis);
      const cv::Mat none = cv::Mat::zeros(gt.size(), CV_8UC1);
      cv::Mat ch2[3] = {r.consistency_mask.empty() ? none : r.consistency_mask, f.mask_gt, r.mask};
      cv::merge(ch2, 3, vis);
      cv::imwrite(dump + "/cons_" + std::to_string(i) + ".png", vis);
    }
    if (verbose) {
      std::printf("frame %3d  gt %6d  mask %6d  missed %6d  false %6d  consistency %6d\n", i, cv::countNonZero(gt),
                  cv::countNonZero(m), cv::countNonZero(gt & ~m), cv::countNonZero(m & ~gt),
                  r.consistency_mask.empty() ? 0 : cv::countNonZero(r.consistency_mask));
    }
  }
  std::printf("frames %zu  IoU %.3f  false-dynamic %.2f %% of static px  missed %.2f %% of dynamic px\n",
              total_ms.size(), uni > 0 ? inter / uni : 1.0, 100.0 * false_dyn / std::max(1.0, static_px),
              100.0 * missed / std::max(1.0, dyn_px));
  std::printf(
      "time/frame [ms] flow+background median %.2f p90 %.2f | segment (network+carry) median %.2f mean %.2f | total "
      "median %.2f\n",
      percentile(flow_bg_ms, 0.5), percentile(flow_bg_ms, 0.9), percentile(seg_ms, 0.5),
      [&] {
        double s = 0;
        for (double v : seg_ms) s += v;
        return seg_ms.empty() ? 0.0 : s / seg_ms.size();
      }(),
      percentile(total_ms, 0.5));
  std::printf("  flow alone median %.2f, background+combination alone median %.2f (partly run beside the flow)\n",
              percentile(flow_ms, 0.5), percentile(bg_ms, 0.5));
  return 0;
}
