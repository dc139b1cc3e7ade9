/// mask_bonn_bench: how many of the tracker's ORB features land on people in a real dynamic
/// RGB-D sequence (Bonn rgbd_bonn_crowd), with and without the dynamic mask.
///
///   mask_bonn_bench [--data DIR] [--model ONNX] [--frames N] [--variants LIST]
///                   [--pose cv|cv-fresh|none] [--no-warp-fit] [--every-n N] [--async] [--rate-hz HZ]
///                   [--threads T] [--verbose]
///
/// Defaults: --data /work/shared/data/rgbd_bonn_crowd_frames200to399, --model
/// /work/shared/models/yolox_nano.onnx, all frames, --variants none,flow,flow_bg,full, --pose cv,
/// 2 OpenCV threads.
///
/// Reference (pass 0): dypho::mask::YoloSegmenter (YOLOX-nano, class person only, score 0.3,
/// input 416) on every UNMASKED colour image; its boxes_image are the person boxes. Its time per
/// call is reported as the detector cost.
/// Variants (one pass each, own masker, frames in order):
///   none     no mask (what the tracker sees without dypho_mask)
///   flow     DynamicMasker, no network, background model off (ego-motion-compensated flow only)
///   flow_bg  DynamicMasker, no network, background model on (the default without a detector)
///   full     DynamicMasker with the detector (--model), flow and background (config/mask.yaml
///            defaults otherwise; --every-n / --async set the network schedule)
/// Features: dypho::tracking::OrbExtractor with TrackingOptions defaults (1000 keypoints, 8
/// levels) on the grey image with the variant's mask (255 = dynamic, no keypoints there).
/// Pose prior for the mask (--pose cv): T_prev_cur by constant velocity from the two previous
/// frames' ground-truth poses (groundtruth.txt with the Bonn marker-to-camera correction,
/// interpolated at the colour stamps), i.e. what tracking hands over; --pose none: no prior (the
/// flow masker removes a global homography instead); --pose cv-fresh: the same prediction marked
/// fresh (MaskPrior::prediction_fresh, as the offline runner's tracking hands it over once it
/// posed the previous frame; without it the mask takes it as stale and fits it to the flow).
/// --no-warp-fit: background_warp_with_flow_fit off (a fresh prediction warps B as it is).
/// --rate-hz HZ: frames arrive at this rate (the loop sleeps until frame i's arrival time i/HZ),
/// so that an async network sees real frame spacing; 0 (default) = as fast as possible.
///
/// Prints per variant (frames 2..N-1, the first two prime the flow and the pose prior):
///   on-people share = keypoints inside a reference person box / all keypoints, pooled over all
///                     frames, and over the frames that have at least one person box (for scale:
///                     the share of the image the boxes cover is printed with the reference; a box
///                     also holds background around the person, so 0 % is not reachable);
///   keypoints/frame, masked fraction (mean over all frames and over the frames without a
///   person box, i.e. false masking of the empty room), frames the masker reported degraded,
///   mask time per frame (median, p90) and for `full` the network time per synchronous call and
///   its mean per frame (amortisation; with --async the network runs beside the loop).

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/mask/dynamic_masker.h"
#include "dypho/mask/yolo_segmenter.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/evaluation.h"
#include "dypho/tools/tum_dataset.h"
#include "dypho/tracking/orb_extractor.h"
#include "dypho/tracking/tracking_options.h"
#include "help_flag.h"

using namespace dypho;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

bool insideAny(const cv::Point2f& p, const std::vector<cv::Rect>& boxes) {
  for (const cv::Rect& b : boxes) {
    if (p.x >= b.x && p.y >= b.y && p.x < b.x + b.width && p.y < b.y + b.height) return true;
  }
  return false;
}

struct VariantStats {
  double kp_all = 0, kp_people_all = 0;    // all frames
  double kp_with = 0, kp_people_with = 0;  // frames with a person box
  int frames = 0, frames_with = 0, degraded = 0;
  std::vector<double> masked, masked_empty_room, mask_ms, net_ms_calls, net_ms_frames;
};

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: mask_bonn_bench [--data DIR] [--model ONNX] [--frames N] [--variants LIST] [--pose cv|cv-fresh|none]\n"
    "                       [--no-warp-fit]\n"
    "                       [--every-n N] [--async] [--rate-hz HZ] [--threads T] [--verbose]\n"
    "How many of the tracker's ORB features land on people in a Bonn crowd sequence, with and without\n"
    "the dynamic mask. Defaults: --data /work/shared/data/rgbd_bonn_crowd_frames200to399, --model\n"
    "/work/shared/models/yolox_nano.onnx, all frames, --variants none,flow,flow_bg,full, --pose cv,\n"
    "2 OpenCV threads.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  std::string data = "/work/shared/data/rgbd_bonn_crowd_frames200to399";
  std::string model = "/work/shared/models/yolox_nano.onnx";
  std::string variants_arg = "none,flow,flow_bg,full", pose = "cv";
  int max_frames = -1, threads = 2, every_n = 1;
  double rate_hz = 0.0;
  bool async = false, verbose = false, warp_fit = true;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << k << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    try {
      if (k == "--data")
        data = value();
      else if (k == "--model")
        model = value();
      else if (k == "--frames")
        max_frames = std::stoi(value());
      else if (k == "--variants")
        variants_arg = value();
      else if (k == "--pose")
        pose = value();
      else if (k == "--every-n")
        every_n = std::stoi(value());
      else if (k == "--async")
        async = true;
      else if (k == "--rate-hz")
        rate_hz = std::stod(value());
      else if (k == "--threads")
        threads = std::stoi(value());
      else if (k == "--verbose")
        verbose = true;
      else if (k == "--no-warp-fit")
        warp_fit = false;
      else {
        std::cerr << "unknown argument " << k << " (see the file comment)\n";
        return 2;
      }
    } catch (const std::exception&) {
      std::cerr << k << ": not a number\n";
      return 2;
    }
  }
  if (pose != "cv" && pose != "cv-fresh" && pose != "none") {
    std::cerr << "--pose cv|cv-fresh|none\n";
    return 2;
  }
  std::vector<std::string> variants;
  {
    std::stringstream s(variants_arg);
    std::string v;
    while (std::getline(s, v, ',')) {
      if (v != "none" && v != "flow" && v != "flow_bg" && v != "full") {
        std::cerr << "unknown variant '" << v << "' (none, flow, flow_bg, full)\n";
        return 2;
      }
      variants.push_back(v);
    }
  }
  cv::setNumThreads(threads);

  std::optional<tools::TumDataset> opened;
  try {
    const tools::CameraConfig camera =
        tools::loadCameraConfig(tools::resolveCameraConfig("bonn", tools::defaultConfigDir()));
    opened.emplace(tools::TumDataset::open(data, camera));
  } catch (const std::exception& e) {
    std::cerr << "cannot open " << data << ": " << e.what() << "\n";
    return 1;
  }
  const tools::TumDataset& dataset = *opened;
  const int n =
      max_frames > 0 ? std::min<int>(max_frames, static_cast<int>(dataset.size())) : static_cast<int>(dataset.size());
  const std::vector<dypho::StampedPose> gt = tools::applyBonnCorrection(dataset.groundtruth());
  std::vector<std::optional<Eigen::Isometry3d>> T_world_cam(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i)
    T_world_cam[static_cast<size_t>(i)] =
        tools::interpolatePose(gt, dataset.entry(static_cast<size_t>(i)).stamp_s, 0.1);

  // Pass 0: reference person boxes on the unmasked images.
  mask::YoloOptions ref_options;
  ref_options.model_path = model;
  ref_options.dynamic_classes = "0";
  mask::YoloSegmenter reference(ref_options);
  if (!reference.ready()) {
    std::cerr << "reference detector not available: " << reference.status() << "\n";
    return 1;
  }
  std::printf("data %s: %d frames, camera bonn, pose prior %s, threads %d\nreference: %s\n", data.c_str(), n,
              pose.c_str(), threads, reference.status().c_str());
  std::vector<std::vector<cv::Rect>> boxes(static_cast<size_t>(n));
  std::vector<double> ref_ms;
  for (int i = 0; i < n; ++i) {
    const RgbdFrame f = dataset.load(static_cast<size_t>(i));
    const mask::SegmentOutput r = reference.segment(f.bgr, cv::Mat());
    if (!r.ok) {
      std::cerr << "reference detector failed on frame " << i << ": " << r.message << "\n";
      return 1;
    }
    boxes[static_cast<size_t>(i)] = r.boxes_image;
    ref_ms.push_back(r.ms);
  }
  int with_people = 0;
  double box_area = 0, box_area_with = 0;  // share of the image inside a person box
  for (int i = 2; i < n; ++i) {
    const std::vector<cv::Rect>& bx = boxes[static_cast<size_t>(i)];
    cv::Mat inside = cv::Mat::zeros(dataset.camera().camera.height, dataset.camera().camera.width, CV_8UC1);
    for (const cv::Rect& b : bx) inside(b & cv::Rect(0, 0, inside.cols, inside.rows)).setTo(255);
    const double share = cv::countNonZero(inside) / static_cast<double>(inside.total());
    box_area += share;
    if (!bx.empty()) {
      ++with_people;
      box_area_with += share;
    }
  }
  std::printf(
      "reference: %d of %d scored frames have a person box; person boxes cover %.1f %% of the image "
      "(%.1f %% on frames with people); detector %.1f ms/call median (%.1f mean)\n",
      with_people, n - 2, 100.0 * box_area / std::max(1, n - 2), 100.0 * box_area_with / std::max(1, with_people),
      percentile(ref_ms, 0.5), mean(ref_ms));

  for (const std::string& variant : variants) {
    mask::DynamicMaskOptions mo;
    if (variant == "flow") mo.background.enabled = false;
    mo.background.warp_with_flow_fit = warp_fit;
    if (variant == "full") {
      mo.yolo.model_path = model;
      mo.yolo.every_n_frames = every_n;
      mo.yolo.async = async;
    }
    std::optional<mask::DynamicMasker> masker;
    if (variant != "none") {
      masker.emplace(mo);
      if (variant == "full" && !masker->segmentReady()) {
        std::cerr << "detector not available: " << masker->segmentStatus() << "\n";
        return 1;
      }
    }
    tracking::OrbExtractor extractor{tracking::TrackingOptions()};
    VariantStats st;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) {
      const RgbdFrame f = dataset.load(static_cast<size_t>(i));
      if (rate_hz > 0.0) std::this_thread::sleep_until(start + std::chrono::duration<double>(i / rate_hz));
      cv::Mat mask;
      mask::MaskResult r;
      if (masker) {
        mask::MaskPrior prior;
        const auto& a = i >= 2 ? T_world_cam[static_cast<size_t>(i - 2)] : std::nullopt;
        const auto& b = i >= 2 ? T_world_cam[static_cast<size_t>(i - 1)] : std::nullopt;
        if (pose != "none" && a && b) prior.T_prev_cur = a->inverse() * *b;
        prior.prediction_fresh = pose == "cv-fresh";
        r = masker->compute(f, prior);
        mask = r.mask;
      }
      cv::Mat grey;
      cv::cvtColor(f.bgr, grey, cv::COLOR_BGR2GRAY);
      const tracking::OrbFeatures feats = extractor.extract(grey, mask);
      if (i < 2) continue;
      const std::vector<cv::Rect>& bx = boxes[static_cast<size_t>(i)];
      int on_people = 0;
      for (const cv::KeyPoint& k : feats.keypoints) on_people += insideAny(k.pt, bx) ? 1 : 0;
      const double kp = static_cast<double>(feats.keypoints.size());
      ++st.frames;
      st.kp_all += kp;
      st.kp_people_all += on_people;
      if (!bx.empty()) {
        ++st.frames_with;
        st.kp_with += kp;
        st.kp_people_with += on_people;
      }
      const double masked = masker ? r.masked_fraction : 0.0;
      st.masked.push_back(masked);
      if (bx.empty()) st.masked_empty_room.push_back(masked);
      if (masker) {
        st.degraded += r.degraded ? 1 : 0;
        st.mask_ms.push_back(r.total_ms);
        st.net_ms_frames.push_back(r.segment_ms);
        if (r.segment_fresh) st.net_ms_calls.push_back(r.segment_ms);
      }
      if (verbose) {
        std::printf("%-7s frame %3d  boxes %d  keypoints %4zu  on people %4d  masked %.3f  %.1f ms%s\n",
                    variant.c_str(), i, static_cast<int>(bx.size()), feats.keypoints.size(), on_people, masked,
                    r.total_ms, r.degraded ? ("  degraded: " + r.message).c_str() : "");
      }
    }
    std::printf(
        "%-7s on-people share %5.1f %% (all frames), %5.1f %% (frames with people) | keypoints/frame %.0f | "
        "masked %.1f %% mean, %.1f %% on frames without people, %d degraded | mask ms median %.1f p90 %.1f",
        variant.c_str(), 100.0 * st.kp_people_all / std::max(1.0, st.kp_all),
        100.0 * st.kp_people_with / std::max(1.0, st.kp_with), st.kp_all / std::max(1, st.frames),
        100.0 * mean(st.masked), 100.0 * mean(st.masked_empty_room), st.degraded, percentile(st.mask_ms, 0.5),
        percentile(st.mask_ms, 0.9));
    if (variant == "full") {
      std::printf(" | network %.1f ms/call median (%zu calls), %.1f ms/frame mean", percentile(st.net_ms_calls, 0.5),
                  st.net_ms_calls.size(), mean(st.net_ms_frames));
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}
