// writeSyntheticDataset: a SyntheticScene as a TUM-layout folder with masks and ground truth.
#include "dypho/tools/synthetic_writer.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "dypho/common/atomic_file.h"
#include "synthetic_internal.h"

namespace fs = std::filesystem;

namespace dypho::tools {
namespace {

constexpr double kDepthScale = 5000.0;  ///< PNG value per metre (TUM convention)

/// "%.6f" seconds of a whole-microsecond stamp, formatted from integers (exact).
std::string stampText(Timestamp stamp_ns) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%lld.%06lld", static_cast<long long>(stamp_ns / 1000000000),
                static_cast<long long>((stamp_ns % 1000000000) / 1000));
  return buf;
}

/// Encodes `img` as PNG in memory and writes it atomically.
void writePngAtomically(const std::string& path, const cv::Mat& img) {
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", img, png)) throw std::runtime_error("PNG encoding failed for '" + path + "'");
  writeFileAtomically(
      path,
      [&](std::ostream& os) {
        os.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
      },
      true);
}

cv::Mat depthToPng16(const cv::Mat& depth_m) {
  cv::Mat out(depth_m.size(), CV_16UC1);
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* z = depth_m.ptr<float>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      const double raw = std::isfinite(z[u]) && z[u] > 0.f ? std::round(z[u] * kDepthScale) : 0.0;
      o[u] = static_cast<std::uint16_t>(std::min(raw, 65535.0));
    }
  }
  return out;
}

const char* walkText(SynthWalk walk) {
  switch (walk) {
    case SynthWalk::kCross:
      return "back and forth across the view";
    case SynthWalk::kStopAndGo:
      return "across the view, standing still for 1-3 s at irregular intervals";
    case SynthWalk::kTowards:
      return "towards the camera and away again along its view direction";
    case SynthWalk::kGroup:
      return "side by side as one group";
  }
  return "";
}

std::string peopleLayoutText(const SynthOptions& o) {
  std::ostringstream ss;
  const bool legacy = synth_detail::usesLegacyPeopleLayout(o);
  if (o.motion == SynthMotion::kLoop) {
    ss << (legacy ? "on rings around the room centre" : "in a formation on two rings")
       << ", walking round with the camera";
    return ss.str();
  }
  if (legacy) {
    return "on elliptic lanes 1.4-2.3 m in front of the camera's home position (layout of "
           "earlier versions)";
  }
  const double d = synth_detail::effectivePeopleDistanceM(o);
  switch (o.walk) {
    case SynthWalk::kTowards:
      ss << "lanes along the view from 3.2 m to " << d << " m";
      break;
    case SynthWalk::kGroup:
      ss << "front row " << d << " m";
      break;
    default:
      ss << "nearest lane " << d << " m, lanes 0.55 m apart";
      break;
  }
  ss << " in front of the camera's home position" << (o.people_distance_m == 0.0 ? " (auto)" : "");
  return ss.str();
}

std::string readme(const SynthOptions& o, const SynthWriteOptions& w, const SynthWriteSummary& s) {
  std::ostringstream ss;
  ss << "DyPho-SLAM synthetic dynamic RGB-D sequence (generated, not recorded).\n\n"
     << "Scene: a 7 x 6 x 3 m room (x in [-3.5, 3.5], y in [-3, 3], z in [0, 3] m, z up) with\n"
     << "procedurally textured walls, floor, ceiling and five furniture boxes, and " << o.people << "\n"
     << "walking people (elliptic cylinders 0.5 m wide, 1.7 m tall, textured clothing).\n"
     << "People: walk " << synthWalkName(o.walk) << " (" << walkText(o.walk) << "); "
     << (o.people_in_view_at_start ? "all inside the image at frame 0" : "random start positions") << "; "
     << peopleLayoutText(o) << ".\n"
     << "Rendered by ray casting with Lambertian shading (one point light + ambient).\n\n"
     << "Options: " << o.toString() << "\n"
     << "Frames: " << s.frames << " over " << s.duration_s << " s; camera path " << s.path_length_m
     << " m; people cover " << 100.0 * s.mean_dynamic_fraction << " % of the pixels on average (max "
     << 100.0 * s.max_dynamic_fraction << " %).\n\n"
     << "Files (TUM RGB-D layout):\n"
     << "  rgb/<stamp>.png    8-bit colour\n"
     << "  depth/<stamp>.png  16-bit, depth [m] = value / 5000, 0 = no measurement\n"
     << "  mask/<stamp>.png   8-bit ground-truth dynamic mask, 255 = person, 0 = static\n"
     << "  rgb.txt depth.txt mask.txt  \"timestamp path\" lists\n"
     << "  groundtruth.txt    \"timestamp tx ty tz qx qy qz qw\": camera optical frame (x right,\n"
     << "                     y down, z forward) in the world, exact\n"
     << "  camera.yaml        intrinsics (pinhole, no distortion), depth_scale\n";
  if (o.depth_noise) {
    ss << "Depth noise: sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m, quantised to 1/5000 m, holes at\n"
       << "depth discontinuities, 1 % random dropout, 0 beyond 8 m.\n";
  } else {
    ss << "Depth: exact (no noise).\n";
  }
  if (o.exposure_s > 0.0 || o.rolling_shutter_s > 0.0) {
    ss << "Colour: exposure " << 1000.0 * o.exposure_s
       << " ms ending at each stamp (motion blur, up to 8 renders averaged; 0 = sharp); rolling\n"
       << "shutter readout " << 1000.0 * o.rolling_shutter_s
       << " ms, the middle row at the stamp (0 = global shutter).\n"
       << "Depth, masks and ground truth are at the stamp (sharp, global shutter).\n";
  }
  if (!w.command_line.empty()) ss << "\nGenerated with:\n  " << w.command_line << "\n";
  return ss.str();
}

}  // namespace

std::string synthCameraYaml(const CameraIntrinsics& c, double depth_scale, double rolling_shutter_readout_ms) {
  std::ostringstream ss;
  ss << std::setprecision(12);
  ss << "# Synthetic pinhole camera written by dypho_synth (registered depth, no distortion).\n"
     << "name: synthetic\n"
     << "width: " << c.width << "\nheight: " << c.height << "\n"
     << "fx: " << c.fx << "\nfy: " << c.fy << "\ncx: " << c.cx << "\ncy: " << c.cy << "\n"
     << "distortion: [" << c.distortion[0] << ", " << c.distortion[1] << ", " << c.distortion[2] << ", "
     << c.distortion[3] << ", " << c.distortion[4] << "]\n"
     << "depth_scale: " << depth_scale << "\n";
  if (rolling_shutter_readout_ms > 0.0) ss << "rolling_shutter_readout_ms: " << rolling_shutter_readout_ms << "\n";
  return ss.str();
}

SynthWriteSummary writeSyntheticDataset(const SynthOptions& options, const std::string& out_dir,
                                        const SynthWriteOptions& write_options) {
  const SyntheticScene scene(options);  // validates
  const fs::path dir(out_dir);
  std::error_code ec;
  for (const char* sub : {"rgb", "depth", "mask"}) {
    fs::create_directories(dir / sub, ec);
    if (ec) {
      throw std::runtime_error("cannot create '" + (dir / sub).string() + "': " + ec.message() +
                               " (check the --out path and its permissions)");
    }
  }
  std::ostringstream rgb_txt, depth_txt, mask_txt, gt_txt;
  const std::string header = "# file: 'dypho_synth " + synthMotionName(options.motion) + "'\n";
  rgb_txt << "# color images\n" << header << "# timestamp filename\n";
  depth_txt << "# depth maps\n" << header << "# timestamp filename\n";
  mask_txt << "# ground-truth dynamic masks (255 = person)\n" << header << "# timestamp filename\n";
  gt_txt << "# ground truth trajectory\n" << header << "# timestamp tx ty tz qx qy qz qw\n";

  SynthWriteSummary summary;
  Eigen::Vector3d last_position = scene.cameraPose(0).translation();
  double dynamic_sum = 0.0;
  for (int i = 0; i < scene.numFrames(); ++i) {
    const SynthFrame f = scene.render(i);
    const std::string stamp = stampText(scene.stampNs(i));
    writePngAtomically((dir / "rgb" / (stamp + ".png")).string(), f.frame.bgr);
    writePngAtomically((dir / "depth" / (stamp + ".png")).string(), depthToPng16(f.frame.depth_m));
    writePngAtomically((dir / "mask" / (stamp + ".png")).string(), f.mask_gt);
    rgb_txt << stamp << " rgb/" << stamp << ".png\n";
    depth_txt << stamp << " depth/" << stamp << ".png\n";
    mask_txt << stamp << " mask/" << stamp << ".png\n";
    Eigen::Quaterniond q(f.T_world_camera.linear());
    if (q.w() < 0) q.coeffs() *= -1.0;
    const Eigen::Vector3d t = f.T_world_camera.translation();
    gt_txt << stamp << std::setprecision(9) << " " << t.x() << " " << t.y() << " " << t.z() << " " << q.x() << " "
           << q.y() << " " << q.z() << " " << q.w() << "\n";

    const double dyn = cv::countNonZero(f.mask_gt) / static_cast<double>(f.mask_gt.total());
    dynamic_sum += dyn;
    summary.max_dynamic_fraction = std::max(summary.max_dynamic_fraction, dyn);
    summary.path_length_m += (t - last_position).norm();
    last_position = t;
    if (write_options.on_frame) write_options.on_frame(f);
    if (write_options.on_progress) write_options.on_progress(i + 1, scene.numFrames());
  }
  summary.frames = scene.numFrames();
  summary.mean_dynamic_fraction = dynamic_sum / summary.frames;
  summary.duration_s = scene.stampSeconds(summary.frames - 1) - scene.stampSeconds(0);

  auto writeText = [&](const char* name, const std::string& text) {
    writeFileAtomically((dir / name).string(), [&](std::ostream& os) { os << text; });
  };
  writeText("rgb.txt", rgb_txt.str());
  writeText("depth.txt", depth_txt.str());
  writeText("mask.txt", mask_txt.str());
  writeText("groundtruth.txt", gt_txt.str());
  writeText("camera.yaml", synthCameraYaml(options.camera, kDepthScale, 1000.0 * options.rolling_shutter_s));
  writeText("README.txt", readme(options, write_options, summary));
  return summary;
}

}  // namespace dypho::tools
