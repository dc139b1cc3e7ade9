/// GaussianTrainer: loss, one optimisation iteration, densification, pruning, opacity reset.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "gaussian_trainer.h"
#include "dypho/mapping/map_renderer.h"

namespace dypho::mapping {
namespace {

AdamLearningRates ratesFrom(const GaussianMapperOptions& o) {
  AdamLearningRates r;
  r.position = o.lr_position;
  r.log_scale = o.lr_log_scale;
  r.rotation = o.lr_rotation;
  r.opacity = o.lr_opacity;
  r.sh_dc = o.lr_sh_dc;
  r.sh_rest = o.lr_sh_rest;
  return r;
}

}  // namespace

GaussianTrainer::GaussianTrainer(const GaussianMapperOptions& o, ComputeDevice d)
    : options(o),
      device(d),
      cuda(d == ComputeDevice::kCuda ? std::make_unique<CudaTrainer>() : nullptr),
      map(o.sh_degree, o.max_gaussians),
      pool(o.resolvedNumThreads(), o.trainingPriority()),
      raster(&pool),
      render_raster(&pool),
      adam(ratesFrom(o)),
      rng(static_cast<unsigned>(o.random_seed)),
      ssim(&pool) {}

GaussianParamsView<float> GaussianTrainer::params() const { return paramsView(map); }

static_assert(kTrainingBlocks == kNumGaussianParams && kParamSh == 4, "CudaTrainer's block layout is GaussianMap's");

TrainingStateView GaussianTrainer::stateView() {
  adam.resize(map);
  grad_accum.resize(map.size(), 0.f);
  grad_count.resize(map.size(), 0);
  TrainingStateView v;
  v.count = map.size();
  v.sh_degree = map.shDegree();
  for (int p = 0; p < kNumGaussianParams; ++p) {
    v.widths[p] = map.width(p);
    v.params[p] = map.data(p);
    v.first_moment[p] = adam.firstMoment(p).data();
    v.second_moment[p] = adam.secondMoment(p).data();
  }
  v.grad_accum = grad_accum.data();
  v.grad_count = grad_count.data();
  return v;
}

void GaussianTrainer::syncToHost() {
  if (!cuda || current != Current::kDevice) return;
  try {
    cuda->download(stateView());
    current = Current::kBoth;
  } catch (const std::runtime_error& e) {
    leaveGpu(e.what());
  }
}

void GaussianTrainer::leaveGpu(const std::string& reason) {
  device_fallback = "CUDA training failed (" + reason +
                    "); training continues on the CPU from the map as last copied from the GPU";
  cuda.reset();
  device = ComputeDevice::kCpu;
  current = Current::kBoth;
}

void GaussianTrainer::hostChanged() {
  if (cuda) current = Current::kHost;
}

GaussianMap& GaussianTrainer::hostMap() {
  syncToHost();
  return map;
}

double GaussianTrainer::iterateCuda(TrainingKeyframe& kf, bool fixed_exposure) {
  if (current == Current::kHost) {
    cuda->upload(stateView());
    current = Current::kBoth;
  }
  if (!cuda->hasTarget(kf.id)) {
    // The keyframe's images in the loss's layout: planar RGB in [0, 1], depth, static mask.
    const int W = kf.bgr.cols, H = kf.bgr.rows;
    const std::size_t npix = static_cast<std::size_t>(W) * H;
    target_rgb.resize(3 * npix);
    target_depth.resize(npix);
    target_mask.resize(npix);
    for (int v = 0; v < H; ++v) {
      const cv::Vec3b* c = kf.bgr.ptr<cv::Vec3b>(v);
      const float* d = kf.depth_m.ptr<float>(v);
      const std::uint8_t* m = kf.static_mask.ptr<std::uint8_t>(v);
      for (int u = 0; u < W; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        for (int ch = 0; ch < 3; ++ch) target_rgb[ch * npix + i] = c[u][2 - ch] * (1.f / 255.f);
        target_depth[i] = d[u];
        target_mask[i] = m[u];
      }
    }
    cuda->setTarget(kf.id, W, H, target_rgb.data(), target_depth.data(), target_mask.data());
  }
  cuda->render(makePinholeView<float>(kf.T_world_camera, kf.camera));
  const CudaLossResult r = cuda->loss(kf.id, options.lambda_depth, options.alpha_weight, options.ssim_weight,
                                      options.exposure_compensation ? kf.exposure : nullptr);
  const double loss = r.loss;
  std::copy(r.exposure_grad, r.exposure_grad + 6, exposure_grad);
  if (options.exposure_compensation && !fixed_exposure) stepExposure(kf);
  cuda->backwardAndStep(adam.nextStep());
  current = Current::kDevice;
  return loss;
}

void GaussianTrainer::renderPinhole(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& pinhole,
                                         Rasterizer<float>& r, RenderResult<float>& out) {
  r.forward(params(), makePinholeView<float>(T_world_camera, pinhole), out);
}

double GaussianTrainer::lossAndGradient(const TrainingKeyframe& kf, const RenderResult<float>& r) {
  const int W = r.width, H = r.height;
  const std::size_t npix = static_cast<std::size_t>(W) * H;
  pix_gc.assign(3 * npix, 0.f);
  pix_gd.assign(npix, 0.f);
  pix_ga.assign(npix, 0.f);
  std::size_t nc = 0, nd = 0;
  for (int v = 0; v < H; ++v) {
    const std::uint8_t* m = kf.static_mask.ptr<std::uint8_t>(v);
    const float* d = kf.depth_m.ptr<float>(v);
    for (int u = 0; u < W; ++u) {
      if (!m[u]) continue;
      ++nc;
      if (d[u] > 0.f) ++nd;
    }
  }
  if (nc == 0) return 0.0;
  const double lambda = options.lambda_depth;
  const float wc = static_cast<float>((1.0 - lambda) / (3.0 * nc));
  const float wd = nd > 0 ? static_cast<float>(lambda / nd) : 0.f;
  const float wa = nd > 0 ? static_cast<float>(options.alpha_weight / nd) : 0.f;
  double l1c = 0.0, l1d = 0.0, l1a = 0.0;
  const bool use_ssim = options.ssim_weight > 0.0;
  if (use_ssim) ssim_target.resize(3 * npix);
  // The colour the loss sees: exp(gain) * rendered + offset per channel (identity when off).
  const float* color = r.color.data();
  float gain[3] = {1.f, 1.f, 1.f};
  if (options.exposure_compensation) {
    exposed.resize(3 * npix);
    for (int ch = 0; ch < 3; ++ch) {
      gain[ch] = std::exp(kf.exposure[ch]);
      const float g = gain[ch], b = kf.exposure[3 + ch];
      const float* in = r.color.data() + ch * npix;
      float* out = exposed.data() + ch * npix;
      for (std::size_t i = 0; i < npix; ++i) out[i] = g * in[i] + b;
    }
    color = exposed.data();
  }
  for (int v = 0; v < H; ++v) {
    const std::uint8_t* m = kf.static_mask.ptr<std::uint8_t>(v);
    const float* d = kf.depth_m.ptr<float>(v);
    const cv::Vec3b* c = kf.bgr.ptr<cv::Vec3b>(v);
    if (use_ssim) {
      for (int u = 0; u < W; ++u)
        for (int ch = 0; ch < 3; ++ch) ssim_target[ch * npix + static_cast<std::size_t>(v) * W + u] = c[u][2 - ch] * (1.f / 255.f);
    }
    for (int u = 0; u < W; ++u) {
      if (!m[u]) continue;
      const std::size_t i = static_cast<std::size_t>(v) * W + u;
      for (int ch = 0; ch < 3; ++ch) {
        const float diff = color[ch * npix + i] - c[u][2 - ch] * (1.f / 255.f);
        l1c += std::abs(diff);
        pix_gc[ch * npix + i] = diff > 0.f ? wc : (diff < 0.f ? -wc : 0.f);
      }
      if (d[u] > 0.f) {
        const float diff = r.depth[i] - d[u];
        l1d += std::abs(diff);
        pix_gd[i] = diff > 0.f ? wd : (diff < 0.f ? -wd : 0.f);
        l1a += 1.f - r.alpha[i];  // alpha <= 1: |1 - A| = 1 - A
        pix_ga[i] = -wa;
      }
    }
  }
  double loss = (1.0 - lambda) * l1c / (3.0 * nc) + (nd > 0 ? (lambda * l1d + options.alpha_weight * l1a) / nd : 0.0);
  if (use_ssim) {
    // + w (1 - SSIM) over the static pixels; its gradient is added to pix_gc.
    const double s = ssim.compute(color, ssim_target.data(), kf.static_mask.data, kf.static_mask.step, W, H,
                                  static_cast<float>(options.ssim_weight), pix_gc.data());
    loss += options.ssim_weight * (1.0 - s);
  }
  if (options.exposure_compensation) {
    // pix_gc holds dL/d(exposed colour): chain rule to the exposure and to the rendered colour.
    for (int ch = 0; ch < 3; ++ch) {
      const float b = kf.exposure[3 + ch];
      float* g = pix_gc.data() + ch * npix;
      const float* ex = exposed.data() + ch * npix;
      double d_gain = 0.0, d_offset = 0.0;
      for (std::size_t i = 0; i < npix; ++i) {
        d_offset += g[i];
        d_gain += g[i] * (ex[i] - b);  // d(exp(k) x + b)/dk = exp(k) x
        g[i] *= gain[ch];
      }
      exposure_grad[ch] = static_cast<float>(d_gain);
      exposure_grad[3 + ch] = static_cast<float>(d_offset);
    }
  }
  return loss;
}

std::size_t GaussianTrainer::correctKeyframePoses(const KeyframePoseCorrections& corrections) {
  syncToHost();
  std::size_t corrected = 0;
  for (const auto& [id, T_world_camera] : corrections) {
    if (!isRigidPose(T_world_camera)) continue;
    for (TrainingKeyframe& kf : keyframes) {
      if (kf.id != id) continue;
      map.transformAnchored(id, T_world_camera * kf.T_world_camera.inverse());
      kf.T_world_camera = T_world_camera;
      ++corrected;
      break;
    }
  }
  if (corrected > 0) hostChanged();
  return corrected;
}

void GaussianTrainer::clear() {
  map.clear();
  keyframes.clear();
  adam.compact(map, std::vector<std::uint8_t>());
  adam.resize(map);
  grad_accum.clear();
  grad_count.clear();
  refine_order.clear();
  if (cuda) cuda->clearTargets();
  hostChanged();
}

double GaussianTrainer::iterate(bool all_keyframes) {
  std::vector<std::size_t>& all = sample_all;
  all.clear();
  for (std::size_t i = 0; i < keyframes.size(); ++i)
    if (keyframes[i].hasImages()) all.push_back(i);
  if (all.empty() || map.size() == 0) return -1.0;
  std::size_t chosen = 0;
  if (all_keyframes) {
    // Refinement: every stored keyframe once per pass, in a shuffled order.
    if (refine_order.empty()) {
      refine_order = all;
      std::shuffle(refine_order.begin(), refine_order.end(), rng);
    }
    chosen = refine_order.back();
    refine_order.pop_back();
    if (chosen >= keyframes.size() || !keyframes[chosen].hasImages()) chosen = all.back();
  } else {
    const std::size_t w = std::min<std::size_t>(all.size(), static_cast<std::size_t>(options.window_size));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const bool global = unit(rng) < options.global_sample_ratio;
    const std::size_t first = global ? 0 : all.size() - w;
    chosen = all[std::uniform_int_distribution<std::size_t>(first, all.size() - 1)(rng)];
  }
  TrainingKeyframe& kf = keyframes[chosen];
  const bool fixed_exposure = chosen == 0;  // keyframe 0 fixes the gauge

  double loss = 0.0;
  if (cuda) {
    try {
      loss = iterateCuda(kf, fixed_exposure);
    } catch (const std::runtime_error& e) {  // CUDA errors; bad input is std::invalid_argument
      leaveGpu(e.what());
      return -1.0;
    }
  } else {
    renderPinhole(kf.T_world_camera, kf.camera, raster, train_out);
    loss = lossAndGradient(kf, train_out);
    raster.backward(PixelGrads<float>{pix_gc.data(), pix_gd.data(), pix_ga.data()}, grads);
    if (options.exposure_compensation && !fixed_exposure) stepExposure(kf);
    adam.step(map, grads);
    grad_accum.resize(map.size(), 0.f);
    grad_count.resize(map.size(), 0);
    for (std::size_t i = 0; i < map.size(); ++i) {
      if (grads.mean2d_norm[i] > 0.f) {
        grad_accum[i] += grads.mean2d_norm[i];
        ++grad_count[i];
      }
    }
  }
  ++iterations;
  last_loss = loss;
  const bool densify = options.densify_interval > 0 && iterations % options.densify_interval == 0;
  const bool reset = options.opacity_reset_interval > 0 && iterations % options.opacity_reset_interval == 0;
  if (densify && cuda) {
    try {
      densifyAndPruneOnDevice();
    } catch (const std::runtime_error& e) {
      leaveGpu(e.what());  // the host structure is still the one before this densify
    }
  }
  if ((densify && !cuda) || reset) {
    syncToHost();  // edits of the host copy
    if (densify && !cuda) densifyAndPrune();
    if (reset) resetOpacity();
    hostChanged();
  }
  return loss;
}

void GaussianTrainer::stepExposure(TrainingKeyframe& kf) {
  // Adam (beta 0.9 / 0.999, eps 1e-8) on the 6 exposure parameters of this keyframe.
  const float lr = static_cast<float>(options.lr_exposure), b1 = 0.9f, b2 = 0.999f;
  ++kf.exposure_steps;
  const float c1 = 1.f - std::pow(b1, static_cast<float>(kf.exposure_steps));
  const float c2 = 1.f - std::pow(b2, static_cast<float>(kf.exposure_steps));
  for (int k = 0; k < 6; ++k) {
    const float g = exposure_grad[k];
    kf.exposure_m[k] = b1 * kf.exposure_m[k] + (1.f - b1) * g;
    kf.exposure_v[k] = b2 * kf.exposure_v[k] + (1.f - b2) * g * g;
    kf.exposure[k] -= lr * (kf.exposure_m[k] / c1) / (std::sqrt(kf.exposure_v[k] / c2) + 1e-8f);
  }
}

void GaussianTrainer::densifyAndPrune() {
  const std::size_t n0 = map.size();
  const float thr = static_cast<float>(options.densify_grad_threshold);
  const float log_split = std::log(static_cast<float>(options.densify_scale_threshold_m));
  std::vector<std::uint8_t> remove(n0, 0);
  std::normal_distribution<float> normal(0.f, 1.f);
  bool full = false;
  for (std::size_t i = 0; i < n0 && !full; ++i) {
    if (grad_count[i] == 0 || grad_accum[i] / grad_count[i] < thr) continue;
    const float* ls = map.data(kParamLogScale) + 3 * i;
    const float max_ls = std::max({ls[0], ls[1], ls[2]});
    if (max_ls <= log_split) {  // small: clone in place (the copy separates under optimisation)
      if (map.duplicate(i) < 0) full = true;
      continue;
    }
    // Large: split into two samples of the Gaussian with 1/1.6 of the scale.
    for (int c = 0; c < 2 && !full; ++c) {
      const long j = map.duplicate(i);
      if (j < 0) {
        full = true;
        break;
      }
      const float* q = map.data(kParamRotation) + 4 * i;
      const Eigen::Quaternionf rot(q[0], q[1], q[2], q[3]);
      const Eigen::Vector3f s(std::exp(ls[0]), std::exp(ls[1]), std::exp(ls[2]));
      const Eigen::Vector3f offset = rot.normalized() * Eigen::Vector3f(s.x() * normal(rng), s.y() * normal(rng), s.z() * normal(rng));
      float* pj = map.data(kParamPosition) + 3 * j;
      for (int k = 0; k < 3; ++k) pj[k] += offset[k];
      float* lj = map.data(kParamLogScale) + 3 * j;
      for (int k = 0; k < 3; ++k) lj[k] -= std::log(1.6f);
    }
    if (!full) remove[i] = 1;
  }
  if (full) ++capacity_hits;
  // Prune: transparent or too large (new Gaussians are kept).
  remove.resize(map.size(), 0);
  const float min_logit = std::log(static_cast<float>(options.prune_min_opacity) / (1.f - static_cast<float>(options.prune_min_opacity)));
  const float max_ls = std::log(static_cast<float>(options.prune_max_scale_m));
  for (std::size_t i = 0; i < map.size(); ++i) {
    const float* ls = map.data(kParamLogScale) + 3 * i;
    if (map.data(kParamOpacity)[i] < min_logit || std::max({ls[0], ls[1], ls[2]}) > max_ls ||
        !std::isfinite(map.data(kParamPosition)[3 * i])) {
      remove[i] = 1;
    }
  }
  adam.resize(map);
  adam.compact(map, remove);
  map.removeIf(remove);
  grad_accum.assign(map.size(), 0.f);
  grad_count.assign(map.size(), 0);
}

void GaussianTrainer::densifyAndPruneOnDevice() {
  if (current == Current::kHost) {
    cuda->upload(stateView());
    current = Current::kBoth;
  }
  DensifySettings s;
  s.grad_threshold = static_cast<float>(options.densify_grad_threshold);
  s.log_split_scale = std::log(static_cast<float>(options.densify_scale_threshold_m));
  s.min_opacity_logit = std::log(static_cast<float>(options.prune_min_opacity) / (1.f - static_cast<float>(options.prune_min_opacity)));
  s.max_log_scale = std::log(static_cast<float>(options.prune_max_scale_m));
  s.seed = static_cast<std::uint32_t>(rng());
  const DensifyOutcome o = cuda->densifyAndPrune(s, options.max_gaussians);
  if (o.capacity_hit) ++capacity_hits;
  // The host copy follows in structure only (ids, anchors, sizes): its values are stale until
  // the next syncToHost(), which the device state (now the newer one) overwrites them with.
  for (const std::uint32_t parent : o.parents) map.duplicate(parent);
  adam.resize(map);
  adam.compact(map, o.remove);
  map.removeIf(o.remove);
  grad_accum.assign(map.size(), 0.f);
  grad_count.assign(map.size(), 0);
  current = Current::kDevice;
}

void GaussianTrainer::resetOpacity() {
  const float cap = std::log(0.01f / 0.99f);
  float* o = map.data(kParamOpacity);
  for (std::size_t i = 0; i < map.size(); ++i) o[i] = std::min(o[i], cap);
  adam.resetBlock(kParamOpacity);
}

}  // namespace dypho::mapping
