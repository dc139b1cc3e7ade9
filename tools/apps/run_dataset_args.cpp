/// dypho_run_dataset's command line.
#include "run_dataset_args.h"
#include "cli_number.h"

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <set>
#include <stdexcept>
#include <optional>
#include <string>

namespace dypho::run_dataset {

void usage(std::ostream& os) {
  os << "usage: dypho_run_dataset --dataset DIR_OR_BAG --out DIR [--camera NAME_OR_YAML]\n"
        "                         [--config YAML] [--mask flow|gt|none] [--max-frames N] [--save-masks]\n"
        "                         [--no-eval] [--no-map] [--eval-every N] [--quiet]\n"
        "                         [--realtime [--realtime-speed S] [--realtime-queue N] | --late-mask-poses]\n"
        "                         [--resume DIR [--localization-only]]\n"
        "       dypho_run_dataset --print-config   (prints the effective options as YAML)\n"
        "  --dataset   TUM-layout folder (rgb.txt, depth.txt[, groundtruth.txt]) or a .bag with\n"
        "              /camera/rgb/image_color, /camera/depth/image, /camera/rgb/camera_info\n"
        "  --out       output folder (created): trajectory.txt (final: frames follow the later\n"
        "              corrections of their keyframe), trajectory_online.txt (poses at frame time),\n"
        "              keyframes.txt, timing.csv, map.pcd,\n"
        "              map.ply (3D Gaussian map), map_render/kf_<id>.png (input | rendered),\n"
        "              view_evaluation.txt (the map at every Nth frame, see --eval-every),\n"
        "              session/ (tracker.bin, map.ply, session.yaml: the whole session, to --resume later;\n"
        "              written when a map was built), and with ground truth: evaluation.txt, trajectory.png\n"
        "  --camera    tum_fr1 | tum_fr2 | tum_fr3 | bonn | path/to/camera.yaml; default: detected\n"
        "  --config    YAML with optional mask:, tracking:, mapping: maps overriding config/*.yaml\n"
        "  --mask      flow (default, the mask core), gt (DIR/mask/*.png, synthetic data), none\n"
        "  --no-map    mask and tracking only: no map is built, trained or written (no map.pcd,\n"
        "              map.ply, map_render/, map PSNR; R_d has no map to render), for trajectory\n"
        "              benchmarks; the trajectory is the same as with the map unless R_d is on\n"
        "  --eval-every N  the saved map is rendered at the final pose of every Nth frame and scored on\n"
        "              its static pixels (the mask tracking used, dilated): PSNR, SSIM, depth L1 and\n"
        "              coverage (opacity >= 0.5), keyframes and novel views apart; default 10, 0 = off\n"
        "  --save-masks  writes the mask tracking used for each frame to OUT/mask/<stamp>.png (8-bit,\n"
        "              255 = dynamic) and OUT/mask.txt (the dypho_synth layout: --mask gt reads it back)\n"
        "  --realtime  frames are released at their stamps (wall clock from the first frame) and the\n"
        "              live policy runs: live mapping, the network asynchronous (yolo_async forced on),\n"
        "              mask and tracking on their own threads as in the graph (the tracking nodelet's\n"
        "              live code: a frame waits for its mask at most 0.1 s, then takes the nearest one);\n"
        "              a frame not taken in time is dropped and counted (no pose). Adds realtime.csv.\n"
        "              Not repeatable. Default: deterministic,\n"
        "              every frame processed as fast as possible.\n"
        "  --realtime-speed S     playback speed factor, > 0 (default 1.0)\n"
        "  --realtime-queue N     frames waiting for the mask before the oldest is skipped (it is tracked\n"
        "                         with the nearest mask), >= 1 (default 2)\n"
        "  --late-mask-poses  deterministic, but the mask gets each frame's pose only after it masked\n"
        "              the next frame, as the live graph's mask does whenever tracking is slower than its\n"
        "              wait (previous_pose_wait_s): every mask starts from a prediction made from older\n"
        "              poses. A repeatable stand-in for that part of the live timing; not with --realtime\n"
        "  --resume DIR  goes on from a saved session: DIR is a previous run's --out (DIR/session is\n"
        "              loaded) or a session folder. Its Gaussian map and tracker map are loaded before the\n"
        "              first frame; each frame is relocalised in them until the camera is found (nothing\n"
        "              is added to the map before), and the poses are in the loaded world frame\n"
        "  --localization-only  with --resume: localise in the loaded maps without changing them (no\n"
        "              keyframes, map points, BA, loop closure or training; tracking.localization_only)\n";
}

double parseNumber(const std::string& key, const std::string& text) {
  const std::optional<double> v = dypho::cli::wholeStringNumber(text);
  if (!v) throw std::runtime_error(key + " needs a number (got '" + text + "')");
  return *v;
}

/// A whole number in [min, max]; else "<key> needs <what>".
long parseWholeNumber(const std::string& key, const std::string& text, double min, double max,
                      const std::string& what) {
  const double n = parseNumber(key, text);
  if (n != std::floor(n) || n < min || n > max) throw std::runtime_error(key + " needs " + what);
  return static_cast<long>(n);
}

/// Options that need or exclude others: throws std::runtime_error naming them.
void checkCombinations(const Args& a) {
  if (!a.print_config && (a.dataset.empty() || a.out.empty())) {
    throw std::runtime_error("--dataset and --out are required");
  }
  if (a.save_masks && a.realtime)
    throw std::runtime_error("--save-masks works in the default (deterministic) mode only");
  if (a.localization_only && a.resume.empty()) {
    throw std::runtime_error("--localization-only needs --resume DIR: there is no map to localise in without one");
  }
  if (a.late_mask_poses && a.realtime) {
    throw std::runtime_error(
        "--late-mask-poses stands in for the live timing in the deterministic mode; --realtime has the timing itself");
  }
  if (a.realtime_option_given && !a.realtime) {
    throw std::runtime_error("--realtime-speed and --realtime-queue need --realtime");
  }
}

Args parseArgs(int argc, char** argv) {
  Args a;
  std::set<std::string> given;  // options with a value: a second one would silently replace the first
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(k + " needs a value");
      if (!given.insert(k).second) {
        throw std::runtime_error(k + " given twice: it takes one value" +
                                 std::string(k == "--config" ? " (put all the keys in one YAML)" : ""));
      }
      return argv[++i];
    };
    if (k == "--dataset")
      a.dataset = value();
    else if (k == "--out")
      a.out = value();
    else if (k == "--camera")
      a.camera = value();
    else if (k == "--config")
      a.config = value();
    else if (k == "--mask")
      a.mask = value();
    else if (k == "--max-frames")
      a.max_frames = parseWholeNumber(k, value(), 0, 1e9, "a whole number >= 0");
    else if (k == "--no-eval")
      a.eval = false;
    else if (k == "--no-map")
      a.build_map = false;
    else if (k == "--quiet")
      a.quiet = true;
    else if (k == "--print-config")
      a.print_config = true;
    else if (k == "--eval-every")
      a.eval_every = static_cast<int>(parseWholeNumber(k, value(), 0, 1e6, "a whole number >= 0"));
    else if (k == "--save-masks")
      a.save_masks = true;
    else if (k == "--realtime")
      a.realtime = true;
    else if (k == "--realtime-speed") {
      a.realtime_options.speed = parseNumber(k, value());
      a.realtime_option_given = true;
    } else if (k == "--realtime-queue") {
      a.realtime_options.queue_capacity_frames =
          static_cast<int>(parseWholeNumber(k, value(), 1, 1000, "a whole number of frames in [1, 1000]"));
      a.realtime_option_given = true;
    } else if (k == "--resume") {
      a.resume = value();
    } else if (k == "--localization-only") {
      a.localization_only = true;
    } else if (k == "--late-mask-poses") {
      a.late_mask_poses = true;
    } else if (k == "-h" || k == "--help") {
      usage(std::cout);
      std::exit(0);
    } else
      throw std::runtime_error("unknown argument '" + k + "'");
  }
  checkCombinations(a);
  a.realtime_options.keep_masks_every_nth = a.build_map ? a.eval_every : 0;
  try {
    a.realtime_options.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return a;
}

}  // namespace dypho::run_dataset
