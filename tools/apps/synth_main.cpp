// dypho_synth: writes a synthetic dynamic RGB-D sequence as a TUM-layout folder (+ a rosbag when
// built with dypho_bag).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include "dypho/tools/synthetic_writer.h"
#ifdef DYPHO_SYNTH_WITH_BAG
#include "dypho/tools/bag_io.h"
#endif

namespace {

const char* kUsage =
    "usage: dypho_synth --out DIR [--frames N] [--motion xyz|halfsphere|static|rpy|loop|fast-rpy]\n"
    "                   [--people 0-8] [--walk cross|stop-and-go|towards|group] [--people-in-view]\n"
    "                   [--people-distance M] [--seed N] [--no-bag] [--no-noise]\n"
    "                   [--exposure-ms MS] [--rolling-shutter-ms MS] [--hard-case kinect-fast]\n"
    "Writes a synthetic room with walking people in the TUM RGB-D layout to DIR (rgb/, depth/,\n"
    "mask/, rgb.txt, depth.txt, groundtruth.txt, camera.yaml, README.txt) and, unless --no-bag,\n"
    "DIR/synthetic.bag with the TUM topic names. Defaults: 300 frames, halfsphere, 2 people,\n"
    "walk cross, people distance 0 (auto), seed 1, Kinect-like depth noise, sharp global-shutter\n"
    "colour.\n"
    "  --motion NAME        camera path (default halfsphere); fast-rpy: fast hand-held turns like TUM\n"
    "                       fr1/rpy (+-20-27 deg, up to about 110 deg/s, mm hand tremor)\n"
    "  --people N           walking people, 0..8 (default 2)\n"
    "  --walk STYLE         cross: back and forth across the view (default); stop-and-go: as cross,\n"
    "                       standing still for 1-3 s now and then; towards: towards the camera from\n"
    "                       the back of the room (3.2 m) and away again; group: side by side as one\n"
    "                       group. The loop motion takes cross only.\n"
    "  --people-in-view     every person is inside the image at frame 0 (default: off; towards and\n"
    "                       loop: at most 5 people)\n"
    "  --people-distance M  distance [m] of the nearest lane (towards: of the near turning point)\n"
    "                       in front of the camera's home position; 0 = auto (default): 1.4, or\n"
    "                       less where 8 people or a group need the room; towards 1.0. At least\n"
    "                       0.6 (static, rpy, fast-rpy) or 0.8 (xyz, halfsphere), at most 1.1-2.75\n"
    "                       by walk and people (the error names the range). With a static camera 6\n"
    "                       people at 0.9 cover about 30 % of the image, 8 at 0.8 about 45 %. Not\n"
    "                       for loop.\n"
    "  --exposure-ms MS     motion blur: the colour image averages up to 8 renders over the MS\n"
    "                       milliseconds before each frame's stamp, camera and people moving\n"
    "                       (0..33.3 at 30 fps; default 0 = sharp). Depth and masks stay sharp.\n"
    "  --rolling-shutter-ms MS\n"
    "                       rolling shutter: colour rows are read out over MS milliseconds, the\n"
    "                       middle row at the frame's stamp, the top row MS/2 earlier (0..33.3;\n"
    "                       default 0 = global shutter). Depth, masks and ground truth: the stamp.\n"
    "  --hard-case NAME     a preset, applied before the other flags (which then override it):\n"
    "                       kinect-fast = --motion fast-rpy --exposure-ms 15\n"
    "                       --rolling-shutter-ms 30 with depth noise (a Kinect turned fast by hand)\n"
    "With at most 3 people, walk cross and neither --people-in-view nor --people-distance, the\n"
    "people walk as in earlier versions (same images for the same seed).\n"
    "Hard cases (static camera):\n"
    "  dypho_synth --out DIR --motion static --people 6 --people-in-view --people-distance 0.9\n"
    "  dypho_synth --out DIR --motion static --people 8 --people-distance 0.8\n"
    "Hard cases (tracking precision: blur, rolling shutter, fast turns):\n"
    "  dypho_synth --out DIR --hard-case kinect-fast\n";

long parseInteger(const std::string& flag, const std::string& text, long lo, long hi) {
  std::size_t used = 0;
  long value = 0;
  try {
    value = std::stol(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || value < lo || value > hi) {
    throw std::runtime_error(flag + " expects an integer in " + std::to_string(lo) + ".." + std::to_string(hi) +
                             ", got '" + text + "'");
  }
  return value;
}

double parseNumber(const std::string& flag, const std::string& text) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !std::isfinite(value)) {
    throw std::runtime_error(flag + " expects a number, got '" + text + "'");
  }
  return value;
}

/// A camera-effect duration given in milliseconds, 0 .. one frame period; returned in seconds.
double parseMillisecondsAsSeconds(const std::string& flag, const std::string& text, double fps) {
  const double ms = parseNumber(flag, text);
  const double max_ms = 1000.0 / fps;
  if (ms < 0.0 || ms > max_ms) {
    std::ostringstream ss;
    ss << flag << " expects milliseconds in 0.." << max_ms << " (one frame at " << fps << " fps), got '" << text << "'";
    throw std::runtime_error(ss.str());
  }
  return std::min(ms / 1000.0, 1.0 / fps);  // 1000 / fps ms may round above 1 / fps s
}

/// Applies the preset --hard-case `name` to `o`.
void applyHardCase(const std::string& name, dypho::tools::SynthOptions& o) {
  if (name == "kinect-fast") {
    o.motion = dypho::tools::SynthMotion::kFastRpy;
    o.exposure_s = 0.015;
    o.rolling_shutter_s = 0.030;
    o.depth_noise = true;
    return;
  }
  throw std::runtime_error("--hard-case expects one of: kinect-fast, got '" + name + "'");
}

struct Args {
  dypho::tools::SynthOptions options;
  std::string out_dir;
  bool write_bag = true;
};

Args parseArgs(int argc, char** argv) {
  Args a;
  // A preset first, wherever it is: the other flags override it.
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--hard-case") applyHardCase(argv[i + 1], a.options);
  }
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--out") {
      a.out_dir = value();
    } else if (flag == "--frames") {
      a.options.frames = static_cast<int>(parseInteger(flag, value(), 1, 1000000));
    } else if (flag == "--motion") {
      a.options.motion = dypho::tools::parseSynthMotion(value());
    } else if (flag == "--people") {
      a.options.people = static_cast<int>(parseInteger(flag, value(), 0, 8));
    } else if (flag == "--walk") {
      a.options.walk = dypho::tools::parseSynthWalk(value());
    } else if (flag == "--people-in-view") {
      a.options.people_in_view_at_start = true;
    } else if (flag == "--people-distance") {
      a.options.people_distance_m = parseNumber(flag, value());
    } else if (flag == "--seed") {
      a.options.seed = static_cast<std::uint32_t>(parseInteger(flag, value(), 0, 4294967295L));
    } else if (flag == "--no-bag") {
      a.write_bag = false;
    } else if (flag == "--no-noise") {
      a.options.depth_noise = false;
    } else if (flag == "--exposure-ms") {
      a.options.exposure_s = parseMillisecondsAsSeconds(flag, value(), a.options.fps);
    } else if (flag == "--rolling-shutter-ms") {
      a.options.rolling_shutter_s = parseMillisecondsAsSeconds(flag, value(), a.options.fps);
    } else if (flag == "--hard-case") {
      value();  // applied before the loop
    } else if (flag == "-h" || flag == "--help") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      throw std::runtime_error("unknown argument '" + flag + "'");
    }
  }
  if (a.out_dir.empty()) throw std::runtime_error("--out DIR is required");
  a.options.validate();
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = parseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dypho_synth: " << e.what() << "\n\n" << kUsage;
    return 2;
  }
  std::string command_line;
  for (int i = 0; i < argc; ++i) command_line += (i ? " " : "") + std::string(argv[i]);

  try {
    dypho::tools::SynthWriteOptions w;
    w.command_line = command_line;
    const bool tty = ::isatty(STDERR_FILENO) != 0;
    w.on_progress = [tty](int done, int total) {
      // One updating line on a terminal, a line per 10 % otherwise (logs stay short).
      if (tty) {
        std::fprintf(stderr, "\rdypho_synth: frame %d/%d (%3.0f %%)%s", done, total, 100.0 * done / total,
                     done == total ? "\n" : "");
      } else if (done == total || (10 * done) / total != (10 * (done - 1)) / total) {
        std::fprintf(stderr, "dypho_synth: frame %d/%d (%3.0f %%)\n", done, total, 100.0 * done / total);
      }
    };
    std::string bag_path;
#ifdef DYPHO_SYNTH_WITH_BAG
    std::unique_ptr<dypho::tools::BagRgbdWriter> bag;
    if (args.write_bag) {
      std::error_code ec;
      std::filesystem::create_directories(args.out_dir, ec);
      bag_path = args.out_dir + "/synthetic.bag";
      bag = std::make_unique<dypho::tools::BagRgbdWriter>(bag_path);
      w.on_frame = [&bag](const dypho::tools::SynthFrame& f) { bag->write(f.frame); };
    }
#else
    if (args.write_bag) {
      std::cerr << "dypho_synth: built without ROS (dypho_bag), so no bag is written; pass --no-bag "
                   "to silence this note\n";
    }
#endif
    const auto t0 = std::chrono::steady_clock::now();
    const auto s = dypho::tools::writeSyntheticDataset(args.options, args.out_dir, w);
#ifdef DYPHO_SYNTH_WITH_BAG
    if (bag) bag->close();
#endif
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("dypho_synth: wrote %d frames (%.2f s of %s motion, camera path %.2f m) to %s\n", s.frames,
                s.duration_s, dypho::tools::synthMotionName(args.options.motion).c_str(), s.path_length_m,
                args.out_dir.c_str());
    std::printf(
        "  people: %d (walk %s), dynamic pixels: mean %.1f %%, max %.1f %%; depth noise: %s; "
        "seed %u\n",
        args.options.people, dypho::tools::synthWalkName(args.options.walk).c_str(), 100.0 * s.mean_dynamic_fraction,
        100.0 * s.max_dynamic_fraction, args.options.depth_noise ? "on" : "off", args.options.seed);
    if (args.options.exposure_s > 0.0 || args.options.rolling_shutter_s > 0.0) {
      std::printf("  colour: exposure %.1f ms (motion blur), rolling shutter readout %.1f ms\n",
                  1000.0 * args.options.exposure_s, 1000.0 * args.options.rolling_shutter_s);
    }
    if (!bag_path.empty()) std::printf("  bag: %s\n", bag_path.c_str());
    std::printf("  took %.1f s (%.1f ms per frame incl. PNG writing)\n", secs, 1000.0 * secs / s.frames);
  } catch (const std::exception& e) {
    std::cerr << "\ndypho_synth: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
