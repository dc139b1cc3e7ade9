// dypho_dataset_to_bag: converts a TUM-layout folder (TUM RGB-D, Bonn, dypho_synth output) into a
// rosbag with the topic names and encodings of the TUM bags, a RealSense or an OpenNI2 driver.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include "dypho/tools/bag_io.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/tum_dataset.h"

namespace {

const char* kUsage =
    "usage: dypho_dataset_to_bag --dataset DIR --out FILE.bag [--camera NAME_OR_YAML]\n"
    "                            [--layout tum|realsense|openni]\n"
    "Writes every associated RGB-D pair of DIR as colour, registered depth and camera_info, with\n"
    "the topic names and encodings of --layout (default tum):\n"
    "  tum        /camera/rgb/image_color (rgb8), /camera/depth/image (32FC1 metres, NaN = no\n"
    "             depth), /camera/rgb/camera_info; frame openni_rgb_optical_frame\n"
    "  realsense  /camera/color/image_raw (rgb8), /camera/aligned_depth_to_color/image_raw (16UC1\n"
    "             millimetres, 0 = no depth), /camera/color/camera_info; frame\n"
    "             camera_color_optical_frame (realsense2_camera with align_depth:=true)\n"
    "  openni     /camera/rgb/image_rect_color (rgb8), /camera/depth_registered/image_raw (16UC1\n"
    "             millimetres, 0 = no depth), /camera/rgb/camera_info; frame\n"
    "             camera_rgb_optical_frame (openni2_launch with depth_registration:=true)\n"
    "Millimetres are rounded to nearest; depth beyond 65.535 m is written as 0. Stamps are the\n"
    "dataset's. Without --camera the camera is detected from DIR (camera.yaml inside it, or a\n"
    "TUM/Bonn name). The bag is written to a temporary file beside FILE.bag and renamed at the end.\n";

struct Args {
  std::string dataset, out, camera;
  dypho::tools::BagLayout layout = dypho::tools::BagLayout::kTum;
};

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--dataset")
      a.dataset = value();
    else if (flag == "--out")
      a.out = value();
    else if (flag == "--camera")
      a.camera = value();
    else if (flag == "--layout")
      a.layout = dypho::tools::parseBagLayout(value());
    else if (flag == "-h" || flag == "--help") {
      std::cout << kUsage;
      std::exit(0);
    } else
      throw std::runtime_error("unknown argument '" + flag + "'");
  }
  if (a.dataset.empty()) throw std::runtime_error("--dataset DIR is required");
  if (a.out.empty()) throw std::runtime_error("--out FILE.bag is required");
  if (!std::filesystem::is_directory(a.dataset)) {
    throw std::runtime_error("dataset folder '" + a.dataset + "' does not exist");
  }
  const std::filesystem::path out_dir = std::filesystem::absolute(a.out).parent_path();
  if (!std::filesystem::is_directory(out_dir)) {
    throw std::runtime_error("the folder of --out, '" + out_dir.string() + "', does not exist");
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = parseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dypho_dataset_to_bag: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
  try {
    const std::string config_dir = dypho::tools::defaultConfigDir();
    std::string camera = args.camera;
    if (camera.empty()) {
      const auto detected = dypho::tools::detectCameraName(args.dataset);
      if (!detected) {
        throw std::runtime_error("cannot tell the camera of '" + args.dataset +
                                 "'; pass --camera NAME_OR_YAML (a name from " + config_dir +
                                 "/cameras or a camera YAML file)");
      }
      camera = *detected;
    }
    const auto cfg = dypho::tools::loadCameraConfig(dypho::tools::resolveCameraConfig(camera, config_dir));
    const auto dataset = dypho::tools::TumDataset::open(args.dataset, cfg);
    const dypho::tools::BagTopics topics = dypho::tools::bagTopicsFor(args.layout);
    std::printf("dypho_dataset_to_bag: %zu RGB-D pairs from %s, camera '%s' -> %s (%s layout: %s %s, %s %s, %s)\n",
                dataset.size(), args.dataset.c_str(), cfg.name.c_str(), args.out.c_str(),
                dypho::tools::bagLayoutName(args.layout).c_str(), topics.rgb.c_str(), topics.colour_encoding.c_str(),
                topics.depth.c_str(), topics.depth_encoding.c_str(), topics.camera_info.c_str());
    // Written beside the target and renamed when complete: an interrupted run leaves no
    // truncated FILE.bag behind (and never replaces a good one).
    const std::string partial = args.out + ".partial-" + std::to_string(::getpid());
    struct RemoveOnError {
      const std::string& path;
      bool keep = false;
      ~RemoveOnError() {
        std::error_code ec;
        if (!keep) std::filesystem::remove(path, ec);
      }
    } cleanup{partial};
    dypho::tools::BagRgbdWriter bag(partial, topics);
    const bool tty = ::isatty(STDERR_FILENO) != 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < dataset.size(); ++i) {
      bag.write(dataset.load(i));
      const std::size_t done = i + 1, total = dataset.size();
      if (tty || done == total || (10 * done) / total != (10 * (done - 1)) / total) {
        std::fprintf(stderr, "%sdypho_dataset_to_bag: %zu/%zu frames (%3.0f %%)%s", tty ? "\r" : "", done, total,
                     100.0 * done / total, tty && done != total ? "" : "\n");
      }
    }
    bag.close();
    std::error_code ec;
    std::filesystem::rename(partial, args.out, ec);
    if (ec) throw std::runtime_error("cannot rename '" + partial + "' to '" + args.out + "': " + ec.message());
    cleanup.keep = true;
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("dypho_dataset_to_bag: wrote %zu frames in %.1f s\n", bag.framesWritten(), secs);
  } catch (const std::exception& e) {
    std::cerr << "dypho_dataset_to_bag: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
