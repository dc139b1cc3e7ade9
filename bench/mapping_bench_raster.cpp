/// mapping_bench_raster: times the CPU Gaussian rasterizer (forward, backward) on a synthetic room
/// made of surface Gaussians, for several Gaussian counts and image sizes.
///
///   mapping_bench_raster [--threads 2] [--repeats 10] [--counts 10000,100000,300000]
///                        [--sizes 640x480,320x240] [--sh-degree 1] [--stages 0|1]
///                        [--isa auto|generic|avx2]
///
/// Scene: Gaussians spread uniformly on the walls and floor of a 6 x 3 x 8 m room seen from inside,
/// flat (one axis 10x thinner), screen size chosen so that the visible ones cover the image about
/// twice (what a trained map looks like), opacity 0.8. Prints one line per case: visible
/// Gaussians, tile entries, median forward and backward ms; with --stages 1 also the medians of
/// the stages (project, bin, composite | backward tiles, chain rule).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/map_renderer.h"
#include "dypho/common/camera.h"
#include "dypho/mapping/rasterizer.h"
#include "help_flag.h"

using namespace dypho;
using namespace dypho::mapping;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

void fillRoom(GaussianMap& map, int n, double sigma_m, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int i = 0; i < n; ++i) {
    GaussianInit g;
    const int face = static_cast<int>(u(rng) * 4.f) % 4;
    const float a = u(rng), b = u(rng);
    Eigen::Vector3f p, normal;
    if (face == 0) {
      p = {-3.f + 6.f * a, -1.5f + 3.f * b, 4.f};
      normal = {0, 0, 1};
    }  // back wall
    else if (face == 1) {
      p = {-3.f + 6.f * a, 1.5f, -1.f + 5.f * b};
      normal = {0, 1, 0};
    }  // floor
    else if (face == 2) {
      p = {-3.f, -1.5f + 3.f * b, -1.f + 5.f * a};
      normal = {1, 0, 0};
    }  // left
    else {
      p = {3.f, -1.5f + 3.f * b, -1.f + 5.f * a};
      normal = {1, 0, 0};
    }  // right
    g.position_w = p;
    const float s = static_cast<float>(std::log(sigma_m));
    g.log_scale = {s, s, s};
    g.log_scale[face == 0 ? 2 : (face == 1 ? 1 : 0)] = s - std::log(10.f);
    g.rotation_wxyz = {1.f, 0.f, 0.f, 0.f};
    g.opacity_logit = std::log(0.8f / 0.2f);
    g.sh = {rgbToShDc(a), rgbToShDc(b), rgbToShDc(0.5f)};
    map.add(g);
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: mapping_bench_raster [--threads 2] [--repeats 10] [--counts 10000,100000,300000]\n"
    "                            [--sizes 640x480,320x240] [--sh-degree 1] [--stages 0|1]\n"
    "                            [--isa auto|generic|avx2]\n"
    "Times the CPU Gaussian rasterizer (forward, backward; with --stages 1 also its stages) on a\n"
    "synthetic room of surface Gaussians, per Gaussian count and image size.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  int threads = 2, repeats = 10, degree = 1, stages = 0;
  std::string counts = "10000,100000,300000", sizes = "640x480,320x240";
  RasterSettings settings;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--threads")
      threads = std::stoi(v);
    else if (k == "--repeats")
      repeats = std::stoi(v);
    else if (k == "--counts")
      counts = v;
    else if (k == "--sizes")
      sizes = v;
    else if (k == "--sh-degree")
      degree = std::stoi(v);
    else if (k == "--stages")
      stages = std::stoi(v);
    else if (k == "--isa" && v == "auto")
      settings.isa = RasterIsa::kAuto;
    else if (k == "--isa" && v == "generic")
      settings.isa = RasterIsa::kGeneric;
    else if (k == "--isa" && v == "avx2")
      settings.isa = RasterIsa::kAvx2;
    else {
      std::fprintf(stderr, "unknown argument %s\n", k.c_str());
      return 1;
    }
  }
  ThreadPool pool(threads);
  Rasterizer<float> raster(&pool, settings);
  std::printf("threads %d, SH degree %d, %d repeats (median), tile kernels %s\n", threads, degree, repeats,
              rasterIsaName(raster.isa()));
  std::printf("%9s %9s %9s %11s %10s %10s %10s\n", "gaussians", "size", "visible", "tile_pairs", "fwd_ms", "bwd_ms",
              "total_ms");
  for (const std::string& cs : split(counts)) {
    const int n = std::stoi(cs);
    for (const std::string& ss : split(sizes)) {
      const int w = std::stoi(ss.substr(0, ss.find('x'))), h = std::stoi(ss.substr(ss.find('x') + 1));
      CameraIntrinsics cam;
      cam.width = w;
      cam.height = h;
      cam.fx = cam.fy = 525.0 * w / 640.0;
      cam.cx = (w - 1) / 2.0;
      cam.cy = (h - 1) / 2.0;
      // Visible area of the room ~ 40 m^2 of surface at ~3.5 m; aim at ~2x coverage.
      const double px_per_gaussian = 2.0 * w * h / (0.5 * n);
      const double sigma_px = std::sqrt(px_per_gaussian / (2.0 * M_PI)) * 0.8;
      const double sigma_m = sigma_px * 3.5 / cam.fx;
      GaussianMap map(degree, n);
      std::mt19937 rng(42);
      fillRoom(map, n, sigma_m, rng);
      const GaussianParamsView<float> params = paramsView(map);
      Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
      T_wc.translation() = Eigen::Vector3d(0, 0, -1.0);
      const auto view = makePinholeView<float>(T_wc, cam);
      RenderResult<float> out;
      GaussianGrads<float> grads;
      std::vector<float> gcolor(3 * w * h), gdepth(w * h);
      std::mt19937 rng2(1);
      std::uniform_real_distribution<float> u(-1.f, 1.f);
      for (auto& v : gcolor) v = u(rng2) * 1e-5f;
      for (auto& v : gdepth) v = u(rng2) * 1e-5f;
      PixelGrads<float> pg{gcolor.data(), gdepth.data(), nullptr};
      std::vector<double> f, b, st[5];
      for (int r = 0; r < repeats + 1; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        raster.forward(params, view, out);
        const auto t1 = std::chrono::steady_clock::now();
        raster.backward(pg, grads);
        const auto t2 = std::chrono::steady_clock::now();
        if (r == 0) continue;  // warm-up (buffers grow)
        f.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        b.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
        const RasterStageTimes& s = raster.stageTimes();
        const double times[5] = {s.project_ms, s.bin_ms, s.composite_ms, s.tiles_back_ms, s.chain_ms};
        for (int k = 0; k < 5; ++k) st[k].push_back(times[k]);
      }
      std::printf("%9d %9s %9zu %11zu %10.1f %10.1f %10.1f\n", n, ss.c_str(), raster.numVisible(),
                  raster.numTileEntries(), median(f), median(b), median(f) + median(b));
      if (stages) {
        std::printf("%31s stages ms: project %.1f, bin %.1f, composite %.1f | tiles %.1f, chain rule %.1f\n", "",
                    median(st[0]), median(st[1]), median(st[2]), median(st[3]), median(st[4]));
      }
    }
  }
  return 0;
}
