/// export_training_frames: the posed RGB-D frames of a TUM-layout sequence at training resolution,
/// in the OpenCV-free file that `mapping_bench_cuda --frames` trains on (training_frames.h).
///
///   export_training_frames --dataset DIR --trajectory T.txt --out FILE [--frames 20] [--downsample 2]
///                          [--bonn-correction]
///
/// Poses come from a TUM trajectory (T_world_camera; e.g. dypho_run_dataset's output, or ground
/// truth; --bonn-correction applies the Bonn marker-to-camera correction to it): each of --frames frames spread evenly
/// over the sequence takes the pose nearest in time (within 20 ms; frames without one are skipped). Distortion is
/// ignored (the shared sequences' colour images are undistorted pinholes or close). No mask: every pixel counts as
/// static.
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

#include "dypho/common/trajectory_io.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/evaluation.h"
#include "dypho/tools/tum_dataset.h"
#include "training_frames.h"
#include "help_flag.h"

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: export_training_frames --dataset DIR --trajectory T.txt --out FILE [--frames 20] [--downsample 2]\n"
    "                              [--bonn-correction]\n"
    "Writes the posed RGB-D frames of a TUM-layout sequence at training resolution into FILE, the\n"
    "frames file `mapping_bench_cuda --frames` trains on. Poses come from the TUM trajectory T.txt\n"
    "(T_world_camera, the nearest within 20 ms); --bonn-correction applies the Bonn marker-to-camera\n"
    "correction to it. --frames frames spread evenly over the sequence, at 1/--downsample resolution.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  std::string dataset_dir, trajectory, out;
  int count = 20, downsample = 2;
  bool bonn = false;
  for (int i = 1; i < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--bonn-correction") {
      bonn = true;
      --i;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s needs a value\n", k.c_str());
      return 2;
    }
    const std::string v = argv[i + 1];
    if (k == "--dataset")
      dataset_dir = v;
    else if (k == "--trajectory")
      trajectory = v;
    else if (k == "--out")
      out = v;
    else if (k == "--frames")
      count = std::stoi(v);
    else if (k == "--downsample")
      downsample = std::stoi(v);
    else {
      std::fprintf(stderr, "unknown argument %s\n", k.c_str());
      return 2;
    }
  }
  if (dataset_dir.empty() || trajectory.empty() || out.empty() || count < 1 || downsample < 1) {
    std::fprintf(stderr,
                 "usage: export_training_frames --dataset DIR --trajectory T.txt --out FILE [--frames 20] "
                 "[--downsample 2] [--bonn-correction]\n");
    return 2;
  }
  try {
    const std::string config_dir = dypho::tools::defaultConfigDir();
    const auto name = dypho::tools::detectCameraName(dataset_dir);
    if (!name) throw std::runtime_error("cannot tell the camera of '" + dataset_dir + "'");
    const auto cfg = dypho::tools::loadCameraConfig(dypho::tools::resolveCameraConfig(*name, config_dir));
    const auto dataset = dypho::tools::TumDataset::open(dataset_dir, cfg);
    std::vector<dypho::StampedPose> poses = dypho::readTumTrajectory(trajectory);
    if (bonn) poses = dypho::tools::applyBonnCorrection(poses);
    dypho::bench::TrainingFrames t;
    t.width = cfg.camera.width / downsample;
    t.height = cfg.camera.height / downsample;
    t.fx = cfg.camera.fx / downsample;
    t.fy = cfg.camera.fy / downsample;
    t.cx = (cfg.camera.cx + 0.5) / downsample - 0.5;
    t.cy = (cfg.camera.cy + 0.5) / downsample - 0.5;
    const std::size_t npix = static_cast<std::size_t>(t.width) * t.height;
    for (int k = 0; k < count; ++k) {
      const std::size_t i = dataset.size() * static_cast<std::size_t>(k) / static_cast<std::size_t>(count);
      const dypho::RgbdFrame f = dataset.load(i);
      const double stamp = static_cast<double>(f.stamp_ns) * 1e-9;
      const dypho::StampedPose* best = nullptr;
      for (const auto& p : poses)
        if (!best || std::abs(p.stamp_s - stamp) < std::abs(best->stamp_s - stamp)) best = &p;
      if (!best || std::abs(best->stamp_s - stamp) > 0.02) continue;
      cv::Mat bgr, depth;
      cv::resize(f.bgr, bgr, cv::Size(t.width, t.height), 0, 0, cv::INTER_AREA);
      cv::resize(f.depth_m, depth, cv::Size(t.width, t.height), 0, 0, cv::INTER_NEAREST);
      dypho::bench::TrainingFrame fr;
      const Eigen::Matrix4d T = best->T_world_camera.matrix();
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) fr.T_world_camera[4 * r + c] = T(r, c);
      fr.rgb.resize(3 * npix);
      fr.depth_m.resize(npix);
      for (int v = 0; v < t.height; ++v)
        for (int u = 0; u < t.width; ++u) {
          const std::size_t p = static_cast<std::size_t>(v) * t.width + u;
          const cv::Vec3b c = bgr.at<cv::Vec3b>(v, u);
          for (int ch = 0; ch < 3; ++ch) fr.rgb[ch * npix + p] = c[2 - ch] / 255.f;
          const float d = depth.at<float>(v, u);
          fr.depth_m[p] = std::isfinite(d) && d > 0.f ? d : 0.f;
        }
      t.frames.push_back(std::move(fr));
    }
    if (t.frames.empty()) throw std::runtime_error("no frame has a pose within 20 ms in '" + trajectory + "'");
    dypho::bench::writeTrainingFrames(out, t);
    std::printf("export_training_frames: %zu frames %dx%d -> %s\n", t.frames.size(), t.width, t.height, out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "export_training_frames: %s\n", e.what());
    return 1;
  }
  return 0;
}
