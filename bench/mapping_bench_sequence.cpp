/// mapping_bench_sequence: builds the Gaussian map of a synthetic sequence from ground-truth
/// poses and masks (mapping alone, no tracking), then reports PSNR on static keyframe pixels,
/// depth L1, the ghost check and memory. Writes side-by-side PNGs into --out.
///
///   mapping_bench_sequence --out DIR [--frames 300] [--motion halfsphere] [--people 2] [--seed 1]
///       [--keyframe-every 10] [--iterations 20] [--final-iterations 0] [--threads 2]
///       [--downsample 2] [--sh-degree 0] [--max-gaussians 300000] [--set KEY=VALUE ...] [--no-pngs]
///   mapping_bench_sequence --out DIR --dataset TUM_DIR [--keyframe-every 10] [...]
///
/// With --dataset: a TUM-layout folder with groundtruth.txt, mapped from ground-truth poses
/// (interpolated at each frame; Bonn correction for the Bonn camera), its mask/ folder when it has
/// one, else no mask (every pixel static); no ghost check.
///
/// Ghost check: at every keyframe, pixels where a person is the first surface (ground-truth mask)
/// and the map renders something (alpha >= 0.5): |rendered depth - static depth| <= 5 cm.
#include <sys/stat.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include <opencv2/imgproc.hpp>

#include "dypho/mapping/gaussian_mapper.h"
#include "dypho/mapping/mapping_options_fields.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/evaluation.h"
#include "dypho/tools/frame_source.h"
#include "dypho/tools/synthetic_scene.h"
#include "help_flag.h"

using namespace dypho;

namespace {

double rssMb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

std::vector<KeyframeKeypoint> detectKeypoints(const RgbdFrame& frame, const cv::Mat& mask) {
  cv::Mat gray;
  cv::cvtColor(frame.bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray, corners, 500, 0.01, 8, mask.empty() ? cv::Mat() : cv::Mat(mask == 0));
  std::vector<KeyframeKeypoint> kps;
  for (const auto& c : corners) {
    KeyframeKeypoint k;
    k.u_px = c.x;
    k.v_px = c.y;
    k.depth_m = frame.depth_m.at<float>(cvRound(c.y), cvRound(c.x));
    if (k.depth_m > 0) kps.push_back(k);
  }
  return kps;
}

/// Maps a real TUM-layout sequence from its ground-truth poses; prints PSNR and depth L1.
int runDataset(const std::string& dataset, const std::string& out, int every, bool pngs,
               const mapping::GaussianMapperOptions& mo) {
  const auto source = tools::openFrameSource(dataset, "", tools::defaultConfigDir());
  std::vector<dypho::StampedPose> gt = source->groundtruth();
  if (gt.empty()) {
    std::cerr << dataset << " has no groundtruth.txt\n";
    return 1;
  }
  if (source->cameraName() == "bonn") gt = tools::applyBonnCorrection(gt);
  mapping::GaussianMapper mapper(mo);
  mapper.setMessageSink([](const std::string& m) { std::cerr << "mapper: " << m << "\n"; });
  mapper.start(4);
  std::size_t used = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < source->size(); i += every) {
    const tools::SourceFrame sf = source->load(i);
    const auto T = tools::interpolatePose(gt, timestampToSeconds(sf.frame.stamp_ns), 0.1);
    if (!T) continue;
    auto kf = std::make_shared<Keyframe>();
    kf->id = static_cast<std::int64_t>(i);
    kf->frame = sf.frame;
    kf->mask = sf.mask;
    kf->T_world_camera = *T;
    kf->keypoints = detectKeypoints(sf.frame, sf.mask);
    mapper.enqueueKeyframe(kf, true);
    ++used;
  }
  mapper.finish();  // waits for the worker, then the final refinement (final_refine_iterations)
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string png_dir = out + "/side_by_side";
  if (pngs) ::mkdir(png_dir.c_str(), 0755);
  const mapping::KeyframeEvaluation ev = mapper.evaluateKeyframes(pngs ? png_dir : "");
  const auto s = mapper.stats();
  mapper.savePly(out + "/map.ply");
  std::printf("dataset: %s (%s), ground-truth poses, %s\n", source->description().c_str(), source->cameraName().c_str(),
              source->hasMasks() ? "dataset masks" : "no mask (all pixels static)");
  std::printf("keyframes %zu (every %d frames), %lld iterations, %zu Gaussians, %.1f s\n", used, every,
              static_cast<long long>(s.iterations), s.num_gaussians, total_s);
  std::printf(
      "PSNR on static keyframe pixels: %.2f dB (%zu keyframes, %dx downsampled; %.2f dB without the keyframes' "
      "exposure), depth L1 %.2f cm\n",
      ev.psnr_db, ev.num_keyframes, mo.train_downsample, ev.psnr_without_exposure_db, ev.depth_l1_m * 100.0);
  std::printf("memory: RSS %.0f MB\n", rssMb());
  return 0;
}

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: mapping_bench_sequence --out DIR [--frames 300] [--motion halfsphere] [--people 2] [--seed 1]\n"
    "           [--keyframe-every 10] [--iterations N] [--final-iterations N] [--threads N]\n"
    "           [--downsample N] [--sh-degree N] [--max-gaussians N] [--set KEY=VALUE ...] [--no-pngs]\n"
    "       mapping_bench_sequence --out DIR --dataset TUM_DIR [--keyframe-every 10] [...]\n"
    "Builds the Gaussian map of a synthetic sequence (or of TUM_DIR) from ground-truth poses and masks,\n"
    "then reports PSNR on static keyframe pixels, depth L1, the ghost check and memory; side-by-side\n"
    "PNGs and the map go to DIR. Mapper options not given keep the defaults of config/mapping.yaml;\n"
    "--set takes any of its keys.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  std::string out, dataset;
  tools::SynthOptions so;
  so.frames = 300;
  int every = 10;
  bool pngs = true;
  mapping::GaussianMapperOptions mo;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto val = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(k + " needs a value");
      return argv[++i];
    };
    if (k == "--out")
      out = val();
    else if (k == "--frames")
      so.frames = std::stoi(val());
    else if (k == "--motion")
      so.motion = tools::parseSynthMotion(val());
    else if (k == "--people")
      so.people = std::stoi(val());
    else if (k == "--seed")
      so.seed = static_cast<std::uint32_t>(std::stoul(val()));
    else if (k == "--keyframe-every")
      every = std::stoi(val());
    else if (k == "--iterations")
      mo.iterations_per_keyframe = std::stoi(val());
    else if (k == "--final-iterations")
      mo.final_refine_iterations = std::stoi(val());
    else if (k == "--set") {  // any GaussianMapperOptions key (config/mapping.yaml), e.g. --set ssim_weight=0.2
      const std::string kv = val();
      const std::size_t eq = kv.find('=');
      bool found = false;
      mapping::visitOptions(mo, [&](const char* key, auto& field, const char*) {
        if (eq == std::string::npos || kv.substr(0, eq) != key) return;
        std::istringstream is(kv.substr(eq + 1));
        found = static_cast<bool>(is >> field);
      });
      if (!found) {
        std::cerr << "--set " << kv << ": not KEY=VALUE with a Gaussian mapper key\n";
        return 1;
      }
    } else if (k == "--threads")
      mo.num_threads = std::stoi(val());
    else if (k == "--downsample")
      mo.train_downsample = std::stoi(val());
    else if (k == "--sh-degree")
      mo.sh_degree = std::stoi(val());
    else if (k == "--max-gaussians")
      mo.max_gaussians = std::stoul(val());
    else if (k == "--no-pngs")
      pngs = false;
    else if (k == "--dataset")
      dataset = val();
    else {
      std::cerr << "unknown argument " << k << "\n";
      return 1;
    }
  }
  if (out.empty()) {
    std::cerr << "--out DIR is required (PNGs and map.ply go there)\n";
    return 1;
  }
  ::mkdir(out.c_str(), 0755);
  if (!dataset.empty()) return runDataset(dataset, out, every, pngs, mo);
  const std::string png_dir = out + "/side_by_side";
  if (pngs) ::mkdir(png_dir.c_str(), 0755);

  tools::SyntheticScene scene(so);
  mapping::GaussianMapper mapper(mo);
  mapper.setMessageSink([](const std::string& m) { std::cerr << "mapper: " << m << "\n"; });
  mapper.start(4);
  std::vector<int> keyframe_indices;
  double mapping_wait_ms = 0.0;
  const auto t_start = std::chrono::steady_clock::now();
  for (int i = 0; i < so.frames; ++i) {
    if (i % every != 0) continue;
    const tools::SynthFrame f = scene.render(i);
    auto kf = std::make_shared<Keyframe>();
    kf->id = i;
    kf->frame = f.frame;
    kf->mask = f.mask_gt;
    kf->T_world_camera = f.T_world_camera;
    kf->keypoints = detectKeypoints(f.frame, f.mask_gt);
    const auto t0 = std::chrono::steady_clock::now();
    mapper.enqueueKeyframe(kf, true);
    mapping_wait_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    keyframe_indices.push_back(i);
    if (i % (every * 20) == 0) {
      const auto s = mapper.stats();
      std::printf("frame %5d: %zu Gaussians, %lld iterations, RSS %.0f MB\n", i, s.num_gaussians,
                  static_cast<long long>(s.iterations), rssMb());
    }
  }
  mapper.finish();  // waits for the worker, then the final refinement (final_refine_iterations)
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  const auto s = mapper.stats();
  const mapping::KeyframeEvaluation ev = mapper.evaluateKeyframes(pngs ? png_dir : "");
  // Ghost check at full resolution.
  std::size_t ghost_px = 0, ghost_ok = 0, ghost_uncovered = 0;
  for (int i : keyframe_indices) {
    const tools::SynthFrame f = scene.render(i);
    const mapping::RenderedView v = mapper.render(f.T_world_camera, f.frame.camera);
    for (int y = 0; y < f.mask_gt.rows; ++y)
      for (int x = 0; x < f.mask_gt.cols; ++x) {
        if (f.mask_gt.at<std::uint8_t>(y, x) == 0) continue;
        const float d = v.depth_m.at<float>(y, x);
        if (!(d > 0.f)) {
          ++ghost_uncovered;
          continue;
        }
        ++ghost_px;
        if (std::abs(d - f.static_depth_m.at<float>(y, x)) <= 0.05f) ++ghost_ok;
      }
  }
  mapper.savePly(out + "/map.ply");
  std::printf("sequence: %s\n", so.toString().c_str());
  std::printf("keyframes %zu (every %d frames), %lld iterations (%d per keyframe + %d final), %zu Gaussians\n",
              keyframe_indices.size(), every, static_cast<long long>(s.iterations), mo.iterations_per_keyframe,
              mo.final_refine_iterations, s.num_gaussians);
  std::printf("time: %.1f s total (incl. rendering the synthetic frames), producer waited %.1f ms per keyframe\n",
              total_s, mapping_wait_ms / std::max<std::size_t>(1, keyframe_indices.size()));
  std::printf(
      "PSNR on static keyframe pixels: %.2f dB (%zu keyframes, %dx downsampled; %.2f dB without the keyframes' "
      "exposure), depth L1 %.2f cm\n",
      ev.psnr_db, ev.num_keyframes, mo.train_downsample, ev.psnr_without_exposure_db, ev.depth_l1_m * 100.0);
  std::printf("ghost check: %.2f %% of %zu covered dynamic pixels within 5 cm of the static depth (%zu uncovered)\n",
              ghost_px ? 100.0 * ghost_ok / ghost_px : 100.0, ghost_px, ghost_uncovered);
  std::printf("memory: %zu Gaussians, RSS %.0f MB\n", s.num_gaussians, rssMb());
  if (pngs) std::printf("side-by-side PNGs: %s\n", png_dir.c_str());
  return 0;
}
