/// mapping_bench_cuda: the CUDA rasterizer against the CPU one in the same run, on a synthetic
/// room of surface Gaussians (the scene of mapping_bench_raster), and training speed.
///
///   mapping_bench_cuda [--counts 10000,100000,1000000] [--size 640x480] [--repeats 20]
///                      [--threads 16] [--cpu-max 1000000] [--train-seconds 5]
///                      [--frames FILE]
///
/// Part 1, per Gaussian count: median wall time of forward, backward and forward+backward on the
/// GPU (device arrays in and out, synchronised; --repeats runs after one warm-up) and on the CPU
/// (--threads threads; counts above --cpu-max skip the CPU), the CPU/GPU ratio, and the GPU stage
/// times (CUDA events). Part 2: training at 100k Gaussians against a target image of the room
/// (the map starts from perturbed colours, opacities and positions): iterations per second of
/// render + masked L1 loss + backward + Adam on each path, and the colour PSNR each reaches in
/// the same wall time (--train-seconds). Part 3, with --frames (a file from export_training_frames,
/// e.g. the shared Bonn crowd frames): a map seeded from the frames' depth (about 100k Gaussians),
/// trained round-robin on them with the mapper's loss (masked L1 colour + depth + opacity, lambda
/// 0.7, alpha weight 0.1; no densification) for the same wall time on each path: iterations per
/// second and the mean colour PSNR over the frames. Builds in the standalone mapping build (no ROS,
/// no OpenCV).
#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "dypho/mapping/adam_math.h"
#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/cuda_rasterizer.h"
#include "dypho/mapping/cuda_trainer.h"
#include "dypho/mapping/rasterizer.h"
#include "kernel_bodies.h"
#include "training_frames.h"
#include "help_flag.h"

using namespace dypho::mapping;
using Clock = std::chrono::steady_clock;

namespace {

#define CHECK(call)                                                   \
  do {                                                                \
    const cudaError_t e = (call);                                     \
    if (e != cudaSuccess) {                                           \
      std::fprintf(stderr, "%s: %s\n", #call, cudaGetErrorString(e)); \
      std::exit(1);                                                   \
    }                                                                 \
  } while (0)

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

/// Host arrays of a map (GaussianParamsView layout), SH degree 1.
struct Scene {
  int n = 0, sh_degree = 1;
  std::vector<float> block[5];  // position, log_scale, rotation, opacity_logit, sh
  static constexpr int kWidths[5] = {3, 3, 4, 1, 12};
  GaussianParamsView<float> view() const {
    GaussianParamsView<float> v;
    v.position = block[0].data();
    v.log_scale = block[1].data();
    v.rotation = block[2].data();
    v.opacity_logit = block[3].data();
    v.sh = block[4].data();
    v.count = n;
    v.sh_degree = sh_degree;
    return v;
  }
};

/// Gaussians on the walls and floor of a 6 x 3 x 8 m room, flat, sized to cover the image about
/// twice, opacity 0.8 (mapping_bench_raster's scene).
Scene room(int n, int width, double fx, std::mt19937& rng) {
  const double px_per_gaussian = 2.0 * width * (width * 3 / 4) / (0.5 * n);
  const double sigma_m = std::sqrt(px_per_gaussian / (2.0 * M_PI)) * 0.8 * 3.5 / fx;
  std::uniform_real_distribution<float> u(0.f, 1.f);
  Scene s;
  s.n = n;
  const float ls = static_cast<float>(std::log(sigma_m)), thin = ls - std::log(10.f);
  const float C0 = static_cast<float>(gs::kShC0);
  for (int i = 0; i < n; ++i) {
    const int face = static_cast<int>(u(rng) * 4.f) % 4;
    const float a = u(rng), b = u(rng);
    float p[3], l[3] = {ls, ls, ls};
    if (face == 0) {
      p[0] = -3.f + 6.f * a;
      p[1] = -1.5f + 3.f * b;
      p[2] = 4.f;
      l[2] = thin;
    } else if (face == 1) {
      p[0] = -3.f + 6.f * a;
      p[1] = 1.5f;
      p[2] = -1.f + 5.f * b;
      l[1] = thin;
    } else if (face == 2) {
      p[0] = -3.f;
      p[1] = -1.5f + 3.f * b;
      p[2] = -1.f + 5.f * a;
      l[0] = thin;
    } else {
      p[0] = 3.f;
      p[1] = -1.5f + 3.f * b;
      p[2] = -1.f + 5.f * a;
      l[0] = thin;
    }
    s.block[0].insert(s.block[0].end(), p, p + 3);
    s.block[1].insert(s.block[1].end(), l, l + 3);
    s.block[2].insert(s.block[2].end(), {1.f, 0.f, 0.f, 0.f});
    s.block[3].push_back(std::log(0.8f / 0.2f));
    const float rgb[3] = {a, b, 0.5f};
    for (int k = 0; k < 12; ++k) s.block[4].push_back(k < 3 ? (rgb[k] - 0.5f) / C0 : 0.f);
  }
  return s;
}

gs::PinholeView<float> camera(int w, int h) {
  gs::PinholeView<float> v{};
  v.width = w;
  v.height = h;
  v.fx = v.fy = 525.f * w / 640.f;
  v.cx = (w - 1) / 2.f;
  v.cy = (h - 1) / 2.f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v.R_cw[i][j] = i == j ? 1.f : 0.f;
  v.center_w[2] = -1.f;  // camera at z = -1 looking down +z
  v.t_cw[2] = 1.f;
  return v;
}

/// Device copies of a scene's arrays.
struct DeviceScene {
  float* block[5] = {};
  GaussianParamsView<float> view(const Scene& s) const {
    GaussianParamsView<float> v = s.view();
    v.position = block[0];
    v.log_scale = block[1];
    v.rotation = block[2];
    v.opacity_logit = block[3];
    v.sh = block[4];
    return v;
  }
};

double psnr(const std::vector<float>& a, const std::vector<float>& b) {
  double se = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) se += (a[i] - b[i]) * (a[i] - b[i]);
  return 10.0 * std::log10(1.0 / std::max(se / a.size(), 1e-12));
}

/// L1 colour loss gradient (mean over pixels and channels) into `g`.
void l1Grad(const std::vector<float>& rendered, const std::vector<float>& target, std::vector<float>& g) {
  const float w = 1.f / static_cast<float>(rendered.size());
  g.resize(rendered.size());
  for (std::size_t i = 0; i < rendered.size(); ++i) {
    const float d = rendered[i] - target[i];
    g[i] = d > 0.f ? w : (d < 0.f ? -w : 0.f);
  }
}

AdamStepSizes stepSizes(int t) {
  const double lr[5] = {5e-4, 5e-3, 1e-3, 5e-2, 1e-2};
  const float c1 = 1.f - std::pow(0.9f, static_cast<float>(t)), c2 = 1.f - std::pow(0.999f, static_cast<float>(t));
  AdamStepSizes s;
  for (int p = 0; p < 5; ++p) s.step[p] = static_cast<float>(lr[p]) / c1;
  s.step_sh_rest = 1.25e-4f / c1;
  s.inv_c2 = 1.f / c2;
  return s;
}

/// The training start: the room with perturbed colours, opacities and positions.
Scene perturbed(const Scene& s, std::mt19937& rng) {
  Scene p = s;
  std::normal_distribution<float> g(0.f, 1.f);
  for (float& v : p.block[0]) v += 0.01f * g(rng);
  for (float& v : p.block[3]) v += 0.5f * g(rng);
  for (int i = 0; i < p.n; ++i)
    for (int k = 0; k < 3; ++k) p.block[4][12 * i + k] += 0.5f * g(rng);
  return p;
}

/// A map of SH degree 0 in GaussianParamsView layout.
struct Map0 {
  int n = 0;
  std::vector<float> block[5];  // widths 3, 3, 4, 1, 3
  GaussianParamsView<float> view() const {
    GaussianParamsView<float> v;
    v.position = block[0].data();
    v.log_scale = block[1].data();
    v.rotation = block[2].data();
    v.opacity_logit = block[3].data();
    v.sh = block[4].data();
    v.count = n;
    v.sh_degree = 0;
    return v;
  }
};

gs::PinholeView<float> frameView(const dypho::bench::TrainingFrames& t, const dypho::bench::TrainingFrame& f) {
  gs::PinholeView<float> v{};
  v.width = t.width;
  v.height = t.height;
  v.fx = static_cast<float>(t.fx);
  v.fy = static_cast<float>(t.fy);
  v.cx = static_cast<float>(t.cx);
  v.cy = static_cast<float>(t.cy);
  const double* T = f.T_world_camera;
  for (int i = 0; i < 3; ++i) {
    v.center_w[i] = static_cast<float>(T[4 * i + 3]);
    for (int j = 0; j < 3; ++j) v.R_cw[i][j] = static_cast<float>(T[4 * j + i]);  // R^T
  }
  for (int i = 0; i < 3; ++i) {
    double t_cw = 0.0;
    for (int j = 0; j < 3; ++j) t_cw -= T[4 * j + i] * T[4 * j + 3];
    v.t_cw[i] = static_cast<float>(t_cw);
  }
  return v;
}

/// Part 3: training on real frames, the same wall time on the CPU and the GPU.
void trainOnFrames(const std::string& path, double seconds, Rasterizer<float>& cpu, bool with_gpu) {
  const dypho::bench::TrainingFrames tf = dypho::bench::readTrainingFrames(path);
  const int W = tf.width, H = tf.height;
  const std::size_t npix = static_cast<std::size_t>(W) * H, nf = tf.frames.size();
  std::vector<gs::PinholeView<float>> views;
  std::size_t valid = 0;
  for (const auto& f : tf.frames) {
    views.push_back(frameView(tf, f));
    for (float d : f.depth_m) valid += d > 0.f;
  }
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid) / 100000.0))));
  const float C0 = static_cast<float>(gs::kShC0);
  Map0 start;
  for (const auto& f : tf.frames) {
    const double* T = f.T_world_camera;
    for (int v = 0; v < H; v += stride)
      for (int u = 0; u < W; u += stride) {
        const std::size_t p = static_cast<std::size_t>(v) * W + u;
        const float d = f.depth_m[p];
        if (!(d > 0.f)) continue;
        const double pc[3] = {(u - tf.cx) / tf.fx * d, (v - tf.cy) / tf.fy * d, d};
        for (int i = 0; i < 3; ++i)
          start.block[0].push_back(
              static_cast<float>(T[4 * i] * pc[0] + T[4 * i + 1] * pc[1] + T[4 * i + 2] * pc[2] + T[4 * i + 3]));
        const float ls = std::log(static_cast<float>(d / tf.fx * stride * 0.5));
        start.block[1].insert(start.block[1].end(), {ls, ls, ls});
        start.block[2].insert(start.block[2].end(), {1.f, 0.f, 0.f, 0.f});
        start.block[3].push_back(0.f);
        for (int ch = 0; ch < 3; ++ch) start.block[4].push_back((f.rgb[ch * npix + p] - 0.5f) / C0);
        ++start.n;
      }
  }
  std::vector<std::uint8_t> mask(npix, 1);
  auto lossParams = [&](const dypho::bench::TrainingFrame& f) {
    std::size_t nd = 0;
    for (float d : f.depth_m) nd += d > 0.f;
    // Every pixel static; lambda_depth 0.7, alpha_weight 0.1, no exposure, no SSIM.
    return train::lossParams(npix, npix, nd, 0.7, 0.1, nullptr, false);
  };
  auto meanPsnr = [&](auto&& render) {
    double sum = 0.0;
    RenderResult<float> out;
    for (std::size_t k = 0; k < nf; ++k) {
      render(k, out);
      sum += psnr(out.color, tf.frames[k].rgb);
    }
    return sum / static_cast<double>(nf);
  };
  // CPU: forward, the mapper's loss (the same per-pixel body as the device), backward, Adam.
  Map0 c = start;
  std::vector<float> m[5], v[5];
  for (int p = 0; p < 5; ++p) m[p].assign(c.block[p].size(), 0.f), v[p].assign(c.block[p].size(), 0.f);
  std::vector<float> gc(3 * npix), gd(npix), ga(npix);
  RenderResult<float> out;
  GaussianGrads<float> grads;
  const double psnr_start =
      meanPsnr([&](std::size_t k, RenderResult<float>& o) { cpu.forward(start.view(), views[k], o); });
  int cpu_iters = 0;
  const auto c0 = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - c0).count() < seconds) {
    const std::size_t k = static_cast<std::size_t>(cpu_iters) % nf;
    cpu.forward(c.view(), views[k], out);
    const train::LossParams L = lossParams(tf.frames[k]);
    float sums[train::kLossSums] = {};
    for (std::size_t i = 0; i < npix; ++i)
      train::l1LossPixel(static_cast<int>(i), L, out.color.data(), out.depth.data(), out.alpha.data(),
                         tf.frames[k].rgb.data(), tf.frames[k].depth_m.data(), mask.data(), gc.data(), gd.data(),
                         ga.data(), sums);
    cpu.backward(PixelGrads<float>{gc.data(), gd.data(), ga.data()}, grads);
    const AdamStepSizes s = stepSizes(++cpu_iters);
    const std::vector<float>* gb[5] = {&grads.position, &grads.log_scale, &grads.rotation, &grads.opacity_logit,
                                       &grads.sh};
    for (int p = 0; p < 5; ++p)
      for (std::size_t i = 0; i < c.block[p].size(); ++i)
        adamUpdate((*gb[p])[i], s.step[p], s.inv_c2, c.block[p][i], m[p][i], v[p][i]);
  }
  const double cpu_s = std::chrono::duration<double>(Clock::now() - c0).count();
  const double cpu_psnr = meanPsnr([&](std::size_t k, RenderResult<float>& o) { cpu.forward(c.view(), views[k], o); });
  if (!with_gpu) {
    std::printf(
        "frames %s: %zu frames %dx%d, %d Gaussians (seed stride %d), PSNR at start %.2f dB; %.1f s: "
        "CPU %d iterations (%.1f it/s) -> %.2f dB; GPU not measured (no device)\n",
        path.c_str(), nf, W, H, start.n, stride, psnr_start, seconds, cpu_iters, cpu_iters / cpu_s, cpu_psnr);
    return;
  }
  // GPU: CudaTrainer.
  CudaTrainer trainer;
  Map0 g = start;
  std::vector<float> m2[5], v2[5], accum(g.n, 0.f);
  std::vector<int> count(g.n, 0);
  TrainingStateView state;
  state.count = g.n;
  state.sh_degree = 0;
  const int widths[5] = {3, 3, 4, 1, 3};
  for (int p = 0; p < 5; ++p) {
    m2[p].assign(g.block[p].size(), 0.f);
    v2[p].assign(g.block[p].size(), 0.f);
    state.widths[p] = widths[p];
    state.params[p] = g.block[p].data();
    state.first_moment[p] = m2[p].data();
    state.second_moment[p] = v2[p].data();
  }
  state.grad_accum = accum.data();
  state.grad_count = count.data();
  trainer.upload(state);
  for (std::size_t k = 0; k < nf; ++k)
    trainer.setTarget(static_cast<std::int64_t>(k), W, H, tf.frames[k].rgb.data(), tf.frames[k].depth_m.data(),
                      mask.data());
  int gpu_iters = 0;
  const auto g0 = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - g0).count() < seconds) {
    const std::size_t k = static_cast<std::size_t>(gpu_iters) % nf;
    trainer.render(views[k]);
    trainer.loss(static_cast<std::int64_t>(k), 0.7, 0.1, 0.0, nullptr);
    trainer.backwardAndStep(stepSizes(++gpu_iters));
  }
  CHECK(cudaDeviceSynchronize());
  const double gpu_s = std::chrono::duration<double>(Clock::now() - g0).count();
  const double gpu_psnr = meanPsnr([&](std::size_t k, RenderResult<float>& o) {
    trainer.render(views[k]);
    trainer.downloadRender(o);
  });
  std::printf(
      "frames %s: %zu frames %dx%d, %d Gaussians (seed stride %d), PSNR at start %.2f dB; %.1f s each: "
      "CPU %d iterations (%.1f it/s) -> %.2f dB; GPU %d iterations (%.1f it/s) -> %.2f dB; ratio %.1fx\n",
      path.c_str(), nf, W, H, start.n, stride, psnr_start, seconds, cpu_iters, cpu_iters / cpu_s, cpu_psnr, gpu_iters,
      gpu_iters / gpu_s, gpu_psnr, (gpu_iters / gpu_s) / std::max(cpu_iters / cpu_s, 1e-9));
}

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: mapping_bench_cuda [--counts 10000,100000,1000000] [--size 640x480] [--repeats 20]\n"
    "                          [--threads 16] [--cpu-max 1000000] [--train-seconds 5] [--frames FILE]\n"
    "The CUDA rasterizer against the CPU one on a synthetic room of surface Gaussians: forward and\n"
    "backward times per Gaussian count, training speed, and with --frames (a file from\n"
    "export_training_frames) training on real frames. Exit status 1 when no CUDA device is usable.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  std::string counts = "10000,100000,1000000", size = "640x480";
  int repeats = 20, threads = 16, cpu_max = 1000000;
  double train_seconds = 5.0;
  std::string frames;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--counts")
      counts = v;
    else if (k == "--size")
      size = v;
    else if (k == "--repeats")
      repeats = std::stoi(v);
    else if (k == "--threads")
      threads = std::stoi(v);
    else if (k == "--cpu-max")
      cpu_max = std::stoi(v);
    else if (k == "--train-seconds")
      train_seconds = std::stod(v);
    else if (k == "--frames")
      frames = v;
    else {
      std::fprintf(stderr, "unknown argument %s\n", k.c_str());
      return 1;
    }
  }
  const int W = std::stoi(size.substr(0, size.find('x'))), H = std::stoi(size.substr(size.find('x') + 1));
  const std::size_t npix = static_cast<std::size_t>(W) * H;
  const gs::PinholeView<float> cam = camera(W, H);
  std::string reason;
  if (cudaDeviceCount(&reason) <= 0) {
    // Nothing of the GPU can be measured; with --frames the CPU half still runs (a check of the
    // frames file and of the CPU figures). Exit status 1: the GPU figures are missing.
    std::printf("no CUDA device (%s): GPU figures not measured\n", reason.c_str());
    if (!frames.empty()) {
      ThreadPool pool(threads);
      Rasterizer<float> cpu(&pool);
      trainOnFrames(frames, train_seconds, cpu, false);
    }
    return 1;
  }
  cudaDeviceProp prop{};
  CHECK(cudaGetDeviceProperties(&prop, 0));
  std::printf("GPU %s, CPU %d threads (tile kernels %s), %dx%d, SH degree 1, median of %d\n", prop.name, threads,
              rasterIsaName(rasterAvx2Available() ? RasterIsa::kAvx2 : RasterIsa::kGeneric), W, H, repeats);
  ThreadPool pool(threads);
  Rasterizer<float> cpu(&pool);
  CudaRasterizer gpu;
  std::printf("%9s %9s %11s | %8s %8s %8s | %8s %8s %8s | %6s | GPU stages ms: project bin composite | tiles chain\n",
              "gaussians", "visible", "tile_pairs", "gpu_fwd", "gpu_bwd", "gpu_f+b", "cpu_fwd", "cpu_bwd", "cpu_f+b",
              "ratio");
  std::vector<float> gc(3 * npix), gd(npix);
  std::mt19937 rng_g(1);
  std::uniform_real_distribution<float> ug(-1e-5f, 1e-5f);
  for (float& v : gc) v = ug(rng_g);
  for (float& v : gd) v = ug(rng_g);
  float *d_gc = nullptr, *d_gd = nullptr;
  CHECK(cudaMalloc(&d_gc, gc.size() * sizeof(float)));
  CHECK(cudaMalloc(&d_gd, gd.size() * sizeof(float)));
  CHECK(cudaMemcpy(d_gc, gc.data(), gc.size() * sizeof(float), cudaMemcpyHostToDevice));
  CHECK(cudaMemcpy(d_gd, gd.data(), gd.size() * sizeof(float), cudaMemcpyHostToDevice));
  for (const std::string& cs : split(counts)) {
    const int n = std::stoi(cs);
    std::mt19937 rng(42);
    const Scene scene = room(n, W, cam.fx, rng);
    DeviceScene ds;
    for (int p = 0; p < 5; ++p) {
      CHECK(cudaMalloc(&ds.block[p], scene.block[p].size() * sizeof(float)));
      CHECK(cudaMemcpy(ds.block[p], scene.block[p].data(), scene.block[p].size() * sizeof(float),
                       cudaMemcpyHostToDevice));
    }
    std::vector<double> gf, gb, cf, cb, st[5];
    const PixelGrads<float> dgrads{d_gc, d_gd, nullptr};
    for (int r = 0; r < repeats + 1; ++r) {
      const auto t0 = Clock::now();
      gpu.forwardOnDevice(ds.view(scene), cam);
      CHECK(cudaDeviceSynchronize());
      const auto t1 = Clock::now();
      gpu.backwardOnDevice(dgrads);
      CHECK(cudaDeviceSynchronize());
      const auto t2 = Clock::now();
      if (r == 0) continue;  // warm-up: buffers grow
      gf.push_back(ms(t0, t1));
      gb.push_back(ms(t1, t2));
      const RasterStageTimes& s = gpu.stageTimes();
      const double times[5] = {s.project_ms, s.bin_ms, s.composite_ms, s.tiles_back_ms, s.chain_ms};
      for (int k = 0; k < 5; ++k) st[k].push_back(times[k]);
    }
    if (n <= cpu_max) {
      RenderResult<float> out;
      GaussianGrads<float> grads;
      const PixelGrads<float> hgrads{gc.data(), gd.data(), nullptr};
      for (int r = 0; r < std::min(repeats, 10) + 1; ++r) {
        const auto t0 = Clock::now();
        cpu.forward(scene.view(), cam, out);
        const auto t1 = Clock::now();
        cpu.backward(hgrads, grads);
        const auto t2 = Clock::now();
        if (r == 0) continue;
        cf.push_back(ms(t0, t1));
        cb.push_back(ms(t1, t2));
      }
    }
    const double g_total = median(gf) + median(gb), c_total = median(cf) + median(cb);
    std::printf("%9d %9zu %11zu | %8.3f %8.3f %8.3f | %8.1f %8.1f %8.1f | %6.0f | %.3f %.3f %.3f | %.3f %.3f\n", n,
                gpu.numVisible(), gpu.numTileEntries(), median(gf), median(gb), g_total, median(cf), median(cb),
                c_total, c_total > 0 ? c_total / g_total : 0.0, median(st[0]), median(st[1]), median(st[2]),
                median(st[3]), median(st[4]));
    for (float* b : ds.block) CHECK(cudaFree(b));
  }

  // Part 2: training speed at 100k Gaussians, same wall time on both paths.
  {
    std::mt19937 rng(7);
    const Scene truth = room(100000, W, cam.fx, rng);
    RenderResult<float> target_image;
    cpu.forward(truth.view(), cam, target_image);
    const std::vector<float> target = target_image.color;
    std::vector<float> depth(npix, 0.f);
    std::vector<std::uint8_t> mask(npix, 1);
    const Scene start = perturbed(truth, rng);
    // CPU: forward + L1 + backward + Adam.
    Scene cpu_scene = start;
    std::vector<float> m[5], v[5];
    for (int p = 0; p < 5; ++p)
      m[p].assign(cpu_scene.block[p].size(), 0.f), v[p].assign(cpu_scene.block[p].size(), 0.f);
    RenderResult<float> out;
    GaussianGrads<float> grads;
    std::vector<float> g;
    int cpu_iters = 0;
    const auto c0 = Clock::now();
    while (std::chrono::duration<double>(Clock::now() - c0).count() < train_seconds) {
      cpu.forward(cpu_scene.view(), cam, out);
      l1Grad(out.color, target, g);
      cpu.backward(PixelGrads<float>{g.data(), nullptr, nullptr}, grads);
      const AdamStepSizes s = stepSizes(++cpu_iters);
      const std::vector<float>* gb[5] = {&grads.position, &grads.log_scale, &grads.rotation, &grads.opacity_logit,
                                         &grads.sh};
      for (int p = 0; p < 5; ++p)
        for (std::size_t i = 0; i < cpu_scene.block[p].size(); ++i) {
          const float step = (p == 4 && i % 12 >= 3) ? s.step_sh_rest : s.step[p];
          adamUpdate((*gb[p])[i], step, s.inv_c2, cpu_scene.block[p][i], m[p][i], v[p][i]);
        }
    }
    const double cpu_s = std::chrono::duration<double>(Clock::now() - c0).count();
    cpu.forward(cpu_scene.view(), cam, out);
    const double cpu_psnr = psnr(out.color, target);
    // GPU: CudaTrainer (device-resident state, loss and Adam on the device).
    CudaTrainer trainer;
    Scene gpu_scene = start;
    std::vector<float> zeros[5], accum(start.n, 0.f);
    std::vector<int> count(start.n, 0);
    TrainingStateView view;
    view.count = start.n;
    view.sh_degree = 1;
    for (int p = 0; p < 5; ++p) {
      zeros[p].assign(gpu_scene.block[p].size(), 0.f);
      view.widths[p] = Scene::kWidths[p];
      view.params[p] = gpu_scene.block[p].data();
    }
    std::vector<float> m2[5], v2[5];
    for (int p = 0; p < 5; ++p) {
      m2[p] = zeros[p];
      v2[p] = zeros[p];
      view.first_moment[p] = m2[p].data();
      view.second_moment[p] = v2[p].data();
    }
    view.grad_accum = accum.data();
    view.grad_count = count.data();
    trainer.upload(view);
    trainer.setTarget(0, W, H, target.data(), depth.data(), mask.data());
    int gpu_iters = 0;
    const auto g0 = Clock::now();
    while (std::chrono::duration<double>(Clock::now() - g0).count() < train_seconds) {
      trainer.render(cam);
      trainer.loss(0, 0.0, 0.0, 0.0, nullptr);
      trainer.backwardAndStep(stepSizes(++gpu_iters));
    }
    CHECK(cudaDeviceSynchronize());
    const double gpu_s = std::chrono::duration<double>(Clock::now() - g0).count();
    trainer.render(cam);
    RenderResult<float> gout;
    trainer.downloadRender(gout);
    const double gpu_psnr = psnr(gout.color, target);
    std::printf(
        "training, 100k Gaussians, %dx%d, %.1f s each: CPU %d iterations (%.1f it/s) -> PSNR %.2f dB; "
        "GPU %d iterations (%.1f it/s) -> PSNR %.2f dB; ratio %.1fx\n",
        W, H, train_seconds, cpu_iters, cpu_iters / cpu_s, cpu_psnr, gpu_iters, gpu_iters / gpu_s, gpu_psnr,
        (gpu_iters / gpu_s) / std::max(cpu_iters / cpu_s, 1e-9));
    // What densify/prune on the host costs the GPU path: one download and one upload of the
    // training state (parameters, Adam moments, statistics) per densify_interval iterations.
    std::vector<double> round_trip;
    for (int r = 0; r < 5; ++r) {
      const auto t0 = Clock::now();
      trainer.download(view);
      trainer.upload(view);
      round_trip.push_back(ms(t0, Clock::now()));
    }
    std::printf("training state download + upload, 100k Gaussians: %.2f ms (per densify_interval iterations)\n",
                median(round_trip));
  }
  CHECK(cudaFree(d_gc));
  CHECK(cudaFree(d_gd));
  if (!frames.empty()) trainOnFrames(frames, train_seconds, cpu, true);
  return 0;
}
