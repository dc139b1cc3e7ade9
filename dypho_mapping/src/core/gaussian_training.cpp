/// GaussianTrainer: loss, one optimisation iteration, densification, pruning, opacity reset.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "gaussian_trainer.h"
#include "dypho/mapping/gaussian_sh.h"
#include "dypho/mapping/map_renderer.h"
#include "dypho/mapping/training_math.h"

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

/// exp([rho, phi]) to first order in the coupling of rotation and translation (rotation exact,
/// translation rho): the retraction of one pose step, whose gradient at 0 is the same.
Eigen::Isometry3d poseStep(const float delta[6]) {
  const Eigen::Vector3d rho(delta[0], delta[1], delta[2]), phi(delta[3], delta[4], delta[5]);
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  const double angle = phi.norm();
  if (angle > 0.0) D.linear() = Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
  D.translation() = rho;
  return D;
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
  device_fallback =
      "CUDA training failed (" + reason + "); training continues on the CPU from the map as last copied from the GPU";
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
    fillTarget(kf);
    cuda->setTarget(kf.id, kf.bgr.cols, kf.bgr.rows, target_rgb.data(), target_depth.data(), target_mask.data());
  }
  cuda->render(makePinholeView<float>(kf.T_world_camera, kf.camera));
  const CudaLossResult r = cuda->loss(kf.id, options.lambda_depth, options.alpha_weight, options.ssim_weight,
                                      options.exposure_compensation ? kf.exposure : nullptr);
  const double loss = r.loss;
  std::copy(r.exposure_grad, r.exposure_grad + 6, exposure_grad);
  if (options.exposure_compensation && !fixed_exposure) stepExposure(kf);
  const bool refine_pose = options.pose_refinement && !fixed_exposure;
  cuda->backwardAndStep(adam.nextStep(), refine_pose ? pose_grad : nullptr,
                        static_cast<float>(options.isotropy_weight));
  if (refine_pose) stepPose(kf, pose_grad);
  current = Current::kDevice;
  return loss;
}

void GaussianTrainer::renderPinhole(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& pinhole,
                                    Rasterizer<float>& r, RenderResult<float>& out) {
  r.forward(params(), makePinholeView<float>(T_world_camera, pinhole), out);
}

TrainingTargetCounts GaussianTrainer::fillTarget(const TrainingKeyframe& kf) {
  const int W = kf.bgr.cols, H = kf.bgr.rows;
  const std::size_t npix = static_cast<std::size_t>(W) * H;
  target_rgb.resize(3 * npix);
  target_depth.resize(npix);
  target_mask.resize(npix);
  TrainingTargetCounts counts;
  for (int v = 0; v < H; ++v) {
    const cv::Vec3b* c = kf.bgr.ptr<cv::Vec3b>(v);
    const float* d = kf.depth_m.ptr<float>(v);
    const std::uint8_t* m = kf.static_mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < W; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * W + u;
      for (int ch = 0; ch < 3; ++ch) target_rgb[ch * npix + i] = c[u][2 - ch] * (1.f / 255.f);
      target_depth[i] = d[u];
      target_mask[i] = m[u];
      if (!m[u]) continue;
      ++counts.static_pixels;
      if (d[u] > 0.f) ++counts.depth_pixels;
    }
  }
  return counts;
}

double GaussianTrainer::lossAndGradient(const TrainingKeyframe& kf, const RenderResult<float>& r) {
  const int W = r.width, H = r.height;
  const std::size_t npix = static_cast<std::size_t>(W) * H;
  const TrainingTargetCounts n = fillTarget(kf);
  pix_gc.assign(3 * npix, 0.f);
  pix_gd.assign(npix, 0.f);
  pix_ga.assign(npix, 0.f);
  std::fill(exposure_grad, exposure_grad + 6, 0.f);
  if (n.static_pixels == 0) return 0.0;
  const bool use_ssim = options.ssim_weight > 0.0;
  const train::LossParams L =
      train::lossParams(npix, n.static_pixels, n.depth_pixels, options.lambda_depth, options.alpha_weight,
                        options.exposure_compensation ? kf.exposure : nullptr, use_ssim);
  double sums[train::kLossSums] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  if (use_ssim) shown.resize(3 * npix);
  for (std::size_t i = 0; i < npix; ++i) {
    train::l1LossPixel(static_cast<int>(i), L, r.color.data(), r.depth.data(), r.alpha.data(), target_rgb.data(),
                       target_depth.data(), target_mask.data(), pix_gc.data(), pix_gd.data(), pix_ga.data(), sums,
                       use_ssim ? shown.data() : nullptr);
  }
  double loss = train::lossFromSums(sums, n.static_pixels, n.depth_pixels, options.lambda_depth, options.alpha_weight);
  if (use_ssim) {
    // + w (1 - SSIM) over the static pixels; its gradient is added to pix_gc, then the exposure's
    // chain rule runs over the sum of both terms.
    const double s = ssim.compute(shown.data(), target_rgb.data(), kf.static_mask.data, kf.static_mask.step, W, H,
                                  static_cast<float>(options.ssim_weight), pix_gc.data());
    loss += options.ssim_weight * (1.0 - s);
    if (L.defer_exposure) {
      for (std::size_t i = 0; i < npix; ++i)
        train::exposureChain(static_cast<int>(i), L, shown.data(), pix_gc.data(), sums);
    }
  }
  for (int k = 0; k < 6; ++k) exposure_grad[k] = static_cast<float>(sums[3 + k]);
  return loss;
}

std::size_t GaussianTrainer::correctKeyframePoses(const KeyframePoseCorrections& corrections) {
  syncToHost();
  std::size_t corrected = 0;
  for (const auto& [id, T_world_camera] : corrections) {
    if (!isRigidPose(T_world_camera)) continue;
    for (TrainingKeyframe& kf : keyframes) {
      if (kf.id != id) continue;
      // A refined pose keeps its offset from the tracked one (T_tracked^-1 T_refined) and moves
      // with the tracker's correction; so do the keyframe's Gaussians.
      const Eigen::Isometry3d T_world_camera_new =
          options.pose_refinement ? T_world_camera * (kf.T_world_camera_tracked.inverse() * kf.T_world_camera)
                                  : T_world_camera;
      map.transformAnchored(id, T_world_camera_new * kf.T_world_camera.inverse());
      kf.T_world_camera = T_world_camera_new;
      kf.T_world_camera_tracked = T_world_camera;
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
    if (options.least_trained_first) {
      chosen = all.back();  // ties: the newest
      for (std::size_t k = all.size(); k-- > first;) {
        if (keyframes[all[k]].trained_iterations < keyframes[chosen].trained_iterations) chosen = all[k];
      }
    } else {
      chosen = all[std::uniform_int_distribution<std::size_t>(first, all.size() - 1)(rng)];
    }
  }
  TrainingKeyframe& kf = keyframes[chosen];
  ++kf.trained_iterations;
  const bool fixed_exposure = chosen == 0;  // keyframe 0 fixes the gauge (exposure and pose)

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
    if (options.pose_refinement && !fixed_exposure) stepPose(kf, grads.pose);
    addIsotropyGradients();
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
  ++kf.exposure_steps;
  float c1 = 1.f, c2 = 1.f;
  adamBiasCorrections(kf.exposure_steps, c1, c2);
  const float step = static_cast<float>(options.lr_exposure) / c1, inv_c2 = 1.f / c2;
  for (int k = 0; k < 6; ++k) {
    adamUpdate(exposure_grad[k], step, inv_c2, kf.exposure[k], kf.exposure_m[k], kf.exposure_v[k],
               kExposureAdamEpsilon);
  }
}

void GaussianTrainer::centreExposureGauge() {
  if (!options.exposure_compensation || keyframes.empty()) return;
  syncToHost();
  double k_mean[3] = {0.0, 0.0, 0.0}, b_mean[3] = {0.0, 0.0, 0.0};
  for (const TrainingKeyframe& kf : keyframes) {
    for (int c = 0; c < 3; ++c) {
      k_mean[c] += kf.exposure[c] / static_cast<double>(keyframes.size());
      b_mean[c] += kf.exposure[3 + c] / static_cast<double>(keyframes.size());
    }
  }
  // A colour 0.5 + C0 dc + sum_k B_k sh_k becomes g (that) + b: the DC coefficient takes the
  // offset, every coefficient the gain (rows are K coefficients x RGB, DC first).
  const int row = map.width(kParamSh);
  float* sh = map.data(kParamSh);
  for (std::size_t i = 0; i < map.size(); ++i) {
    float* coefficients = sh + i * static_cast<std::size_t>(row);
    for (int c = 0; c < 3; ++c) {
      const double g = std::exp(k_mean[c]);
      coefficients[c] = static_cast<float>(g * coefficients[c] + (0.5 * (g - 1.0) + b_mean[c]) / gs::kShC0);
      for (int k = 3 + c; k < row; k += 3) coefficients[k] = static_cast<float>(g * coefficients[k]);
    }
  }
  // exp(k) C + b = exp(k - k_mean) (g C + b_mean) + (b - exp(k - k_mean) b_mean).
  for (TrainingKeyframe& kf : keyframes) {
    for (int c = 0; c < 3; ++c) {
      kf.exposure[c] = static_cast<float>(kf.exposure[c] - k_mean[c]);
      kf.exposure[3 + c] = static_cast<float>(kf.exposure[3 + c] - std::exp(kf.exposure[c]) * b_mean[c]);
    }
  }
  hostChanged();
}

void GaussianTrainer::addIsotropyGradients() {
  if (!(options.isotropy_weight > 0.0) || map.size() == 0) return;
  const float weight = static_cast<float>(options.isotropy_weight) / static_cast<float>(map.size());
  const float* log_scale = map.data(kParamLogScale);
  for (std::size_t i = 0; i < map.size(); ++i) {
    train::addIsotropyGradient(log_scale + 3 * i, grads.mean2d_norm[i], weight, grads.log_scale.data() + 3 * i);
  }
}

void GaussianTrainer::stepPose(TrainingKeyframe& kf, const float grad[6]) {
  ++kf.pose_steps;
  float c1 = 1.f, c2 = 1.f;
  adamBiasCorrections(kf.pose_steps, c1, c2);
  const float inv_c2 = 1.f / c2;
  float delta[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};  // (rho [m], phi [rad]), Adam moves it from 0
  for (int k = 0; k < 6; ++k) {
    const double lr = k < 3 ? options.lr_pose_translation_m : options.lr_pose_rotation_rad;
    adamUpdate(grad[k], static_cast<float>(lr) / c1, inv_c2, delta[k], kf.pose_m[k], kf.pose_v[k]);
  }
  const Eigen::Isometry3d T_camera_world_new = poseStep(delta) * kf.T_world_camera.inverse();
  Eigen::Isometry3d T_world_camera_new = T_camera_world_new.inverse();
  // Thousands of small steps: keep the rotation orthonormal (isRigidPose checks it).
  T_world_camera_new.linear() = Eigen::Quaterniond(T_world_camera_new.linear()).normalized().toRotationMatrix();
  const Eigen::Isometry3d offset = kf.T_world_camera_tracked.inverse() * T_world_camera_new;
  if (offset.translation().norm() > options.pose_refinement_max_translation_m ||
      Eigen::AngleAxisd(offset.linear()).angle() > options.pose_refinement_max_rotation_rad) {
    ++kf.pose_steps_refused;
    return;
  }
  kf.T_world_camera = T_world_camera_new;
}

DensifySettings GaussianTrainer::nextDensifySettings() {
  return train::densifySettings(options.densify_grad_threshold, options.densify_scale_threshold_m,
                                options.prune_min_opacity, options.prune_max_scale_m,
                                static_cast<std::uint32_t>(rng()));
}

void GaussianTrainer::densifyAndPrune() {
  const DensifySettings s = nextDensifySettings();
  const std::size_t n0 = map.size();
  std::vector<std::uint8_t> remove(n0, 0);
  bool full = false;
  // Children are appended in parent order; the first that does not fit ends the pass (the device
  // pass cuts its appended rows at the same place).
  for (std::size_t i = 0; i < n0 && !full; ++i) {
    const std::uint32_t children =
        train::densifyChildren(grad_accum[i], grad_count[i], map.data(kParamLogScale) + 3 * i, s);
    if (children == 1 && map.duplicate(i) < 0) full = true;  // small: clone in place
    if (children != 2) continue;
    for (std::uint32_t k = 0; k < 2 && !full; ++k) {  // large: split into two samples
      const long j = map.duplicate(i);
      if (j < 0) {
        full = true;
        break;
      }
      train::splitChild(s.seed, static_cast<std::uint32_t>(i), k, map.data(kParamLogScale) + 3 * i,
                        map.data(kParamRotation) + 4 * i, map.data(kParamPosition) + 3 * j,
                        map.data(kParamLogScale) + 3 * j);
    }
    if (!full) remove[i] = 1;
  }
  if (full) ++capacity_hits;
  // Prune: transparent, too large or non-finite (new Gaussians included).
  remove.resize(map.size(), 0);
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (train::isPruned(map.data(kParamLogScale) + 3 * i, map.data(kParamOpacity)[i], map.data(kParamPosition)[3 * i],
                        s)) {
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
  const DensifySettings s = nextDensifySettings();
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
  const float cap = train::opacityLogit(train::kOpacityResetValue);
  float* o = map.data(kParamOpacity);
  for (std::size_t i = 0; i < map.size(); ++i) o[i] = std::min(o[i], cap);
  adam.resetBlock(kParamOpacity);
}

}  // namespace dypho::mapping
