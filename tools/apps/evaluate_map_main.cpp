/// dypho_evaluate_map: scores a saved Gaussian map (map.ply) at the estimated pose of every Nth
/// frame of a sequence, on static pixels: PSNR, SSIM, depth L1 and coverage, keyframes and novel
/// views apart (view_evaluation.h). For the graph's saved map and trajectory, or any run's.
///
///   dypho_evaluate_map --map map.ply --dataset DIR_OR_BAG --estimate trajectory.txt
///                      [--keyframes keyframes.txt] [--masks DIR] [--every N] [--dilation PX]
///                      [--camera NAME_OR_YAML] [--config YAML] [--out view_evaluation.txt]

#include <sys/stat.h>

#include <cmath>
#include <iostream>
#include <set>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include "dypho/common/trajectory_io.h"
#include "dypho/mapping/gaussian_map_io.h"
#include "dypho/pipeline/pipeline_options.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/frame_source.h"
#include "dypho/tools/map_views.h"
#include "cli_number.h"

namespace {

using namespace dypho;

struct Args {
  std::string map, dataset, estimate, keyframes, masks, camera, config, out;
  mapping::ViewEvaluationOptions view;
};

constexpr const char* kUsage =
    "usage: dypho_evaluate_map --map map.ply --dataset DIR_OR_BAG --estimate trajectory.txt [options]\n"
    "  --map FILE        the saved Gaussian map (3DGS PLY: the runner's or the graph's map.ply)\n"
    "  --dataset PATH    the sequence it was built from: TUM-layout folder or .bag\n"
    "  --estimate FILE   the estimated trajectory, TUM format (trajectory.txt)\n"
    "  --keyframes FILE  keyframe stamps, TUM format (default: keyframes.txt beside --estimate, if there):\n"
    "                    views of keyframes and of the other frames (novel views) are reported apart\n"
    "  --masks DIR       dynamic masks as dypho_run_dataset --save-masks writes them (DIR/mask.txt);\n"
    "                    without it every pixel is scored, people included\n"
    "  --every N         every Nth frame is scored (default 10)\n"
    "  --dilation PX     the dynamic mask is grown by PX before scoring (default 5)\n"
    "  --camera NAME     tum_fr1 | tum_fr2 | tum_fr3 | bonn | camera YAML (default: detected)\n"
    "  --config YAML     the run's --config (the map's SH degree and Gaussian cap)\n"
    "  --out FILE        write the scores there, atomically (default: print only)\n";

int wholeNumber(const std::string& flag, const std::string& text, int min) {
  const std::optional<double> v = dypho::cli::wholeStringNumber(text);
  if (!v || *v != std::floor(*v) || *v < min || *v > 1e6)
    throw std::invalid_argument(flag + " needs a whole number >= " + std::to_string(min) + ", got '" + text + "'");
  return static_cast<int>(*v);
}

Args parseArgs(int argc, char** argv) {
  Args a;
  std::set<std::string> given;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (i + 1 >= argc) throw std::invalid_argument("missing value after " + flag);
    if (!given.insert(flag).second) throw std::invalid_argument(flag + " given twice");
    const std::string value = argv[++i];
    if (flag == "--map")
      a.map = value;
    else if (flag == "--dataset")
      a.dataset = value;
    else if (flag == "--estimate")
      a.estimate = value;
    else if (flag == "--keyframes")
      a.keyframes = value;
    else if (flag == "--masks")
      a.masks = value;
    else if (flag == "--camera")
      a.camera = value;
    else if (flag == "--config")
      a.config = value;
    else if (flag == "--out")
      a.out = value;
    else if (flag == "--every")
      a.view.every_nth_frame = wholeNumber(flag, value, 1);
    else if (flag == "--dilation")
      a.view.mask_dilation_px = wholeNumber(flag, value, 0);
    else
      throw std::invalid_argument("unknown argument '" + flag + "'");
  }
  if (a.map.empty() || a.dataset.empty() || a.estimate.empty())
    throw std::invalid_argument("--map, --dataset and --estimate are required");
  if (a.keyframes.empty()) {
    const std::size_t slash = a.estimate.find_last_of('/');
    const std::string beside =
        (slash == std::string::npos ? std::string() : a.estimate.substr(0, slash + 1)) + "keyframes.txt";
    struct stat st {};
    if (::stat(beside.c_str(), &st) == 0) a.keyframes = beside;
  }
  return a;
}

int run(const Args& args) {
  const std::string config_dir = tools::defaultConfigDir();
  const pipeline::PipelineOptions options = pipeline::loadPipelineOptions(config_dir, args.config);
  const mapping::GaussianMapperOptions& g = options.mapping.gaussian;
  std::string note;
  const mapping::GaussianMap map = mapping::loadGaussianPly(args.map, g.sh_degree, g.max_gaussians, &note);
  if (!note.empty()) std::cerr << "dypho_evaluate_map: " << note << "\n";
  const std::unique_ptr<tools::FrameSource> source = tools::openFrameSource(args.dataset, args.camera, config_dir);
  const std::vector<StampedPose> trajectory = readTumTrajectory(args.estimate);
  std::vector<double> keyframe_stamps_s;
  if (!args.keyframes.empty()) {
    for (const StampedPose& p : readTumTrajectory(args.keyframes)) keyframe_stamps_s.push_back(p.stamp_s);
  }
  tools::ViewMaskLookup mask_of;
  if (!args.masks.empty()) {
    mask_of = tools::masksFromFolder(args.masks);
  } else {
    std::cerr << "dypho_evaluate_map: no --masks: every pixel is scored, moving people count against the map\n";
  }
  const tools::MapViewRun run = tools::evaluateMapViews(map, *source, source->size(), trajectory, keyframe_stamps_s,
                                                        mask_of, args.view, g.resolvedNumThreads());
  std::cout << "map:          " << args.map << " (" << map.size() << " Gaussians)\n"
            << run.evaluation.report() << "              " << run.notes() << "\n";
  if (!args.out.empty()) {
    mapping::writeViewEvaluation(args.out, run.evaluation);
    std::cout << "written:      " << args.out << "\n";
  }
  return run.evaluation.views.empty() ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parseArgs(argc, argv));
  } catch (const std::exception& e) {
    std::cerr << "dypho_evaluate_map: error: " << e.what() << "\n" << kUsage;
    return 1;
  }
}
