/// GaussianMapper: public API, worker thread, rendering for callers, evaluation and files.
#include "dypho/mapping/gaussian_mapper.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/common/atomic_file.h"
#include "dypho/mapping/gaussian_ply.h"
#include "gaussian_mapper_impl.h"

namespace dypho::mapping {

GaussianMapper::GaussianMapper(const GaussianMapperOptions& options) : options_(options) {
  options_.validate();
  impl_ = std::make_unique<Impl>(options_);
}

GaussianMapper::~GaussianMapper() { stop(); }

AddKeyframeResult GaussianMapper::addKeyframe(const Keyframe& keyframe) {
  AddKeyframeResult r;
  const std::string problem = checkKeyframe(keyframe);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!problem.empty()) {
    ++impl_->skipped;
    r.message = "keyframe " + std::to_string(keyframe.id) + " skipped: " + problem;
    return r;
  }
  for (const auto& kf : impl_->keyframes) {
    if (kf.id == keyframe.id) {
      impl_->map.transformAnchored(kf.id, keyframe.T_world_camera * kf.T_world_camera.inverse());
      for (auto& k : impl_->keyframes)
        if (k.id == keyframe.id) k.T_world_camera = keyframe.T_world_camera;
      r.added = true;
      r.message = "keyframe " + std::to_string(keyframe.id) + " already in the map: re-anchored to the new pose";
      return r;
    }
  }
  r = impl_->integrate(keyframe);
  if (!r.added) ++impl_->skipped;
  return r;
}

double GaussianMapper::optimize(int iterations) {
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < iterations; ++i) {
    std::lock_guard<std::mutex> lock(mutex_);
    const double l = impl_->iterate();
    if (l < 0) break;
    sum += l;
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

void GaussianMapper::start(std::size_t queue_capacity) {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  if (worker_.joinable()) return;
  queue_capacity_ = std::max<std::size_t>(1, queue_capacity);
  stop_ = false;
  worker_ = std::thread([this] { workerLoop(); });
}

bool GaussianMapper::enqueueKeyframe(KeyframeConstPtr keyframe, bool block_when_full) {
  if (!keyframe) return false;
  {
    std::unique_lock<std::mutex> lock(queue_mutex_);
    if (worker_.joinable()) {
      bool kept_all = true;
      if (block_when_full) {
        queue_cv_.wait(lock, [&] { return stop_ || queue_.size() < queue_capacity_; });
      } else if (queue_.size() >= queue_capacity_) {
        queue_.pop_front();
        ++dropped_;
        kept_all = false;
      }
      queue_.push_back(std::move(keyframe));
      queue_cv_.notify_all();
      return kept_all;
    }
  }
  const AddKeyframeResult r = addKeyframe(*keyframe);
  if (!r.message.empty() && sink_) sink_(r.message);
  optimize(options_.iterations_per_keyframe);
  return true;
}

void GaussianMapper::workerLoop() {
  for (;;) {
    KeyframeConstPtr kf;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      kf = std::move(queue_.front());
      queue_.pop_front();
      worker_busy_ = true;
      queue_cv_.notify_all();
    }
    try {
      const AddKeyframeResult r = addKeyframe(*kf);
      if (!r.message.empty() && sink_) sink_(r.message);
      for (int i = 0; i < options_.iterations_per_keyframe; ++i) {
        {
          std::lock_guard<std::mutex> lock(queue_mutex_);
          if (stop_) break;
        }
        optimize(1);
      }
    } catch (const std::exception& e) {
      if (sink_) sink_(std::string("mapping worker: ") + e.what());
    }
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      worker_busy_ = false;
    }
    queue_cv_.notify_all();
  }
}

void GaussianMapper::waitUntilIdle() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  queue_cv_.wait(lock, [&] { return !worker_.joinable() || stop_ || (queue_.empty() && !worker_busy_); });
}

double GaussianMapper::finish() {
  waitUntilIdle();
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < options_.final_refine_iterations; ++i) {
    std::lock_guard<std::mutex> lock(mutex_);
    const double l = impl_->iterate(/*all_keyframes=*/true);
    if (l < 0) break;
    sum += l;
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

void GaussianMapper::stop() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
    queue_.clear();
  }
  queue_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void GaussianMapper::setMessageSink(std::function<void(const std::string&)> sink) { sink_ = std::move(sink); }

bool GaussianMapper::updateKeyframePose(std::int64_t id, const Eigen::Isometry3d& T_world_camera) {
  if (!T_world_camera.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T_world_camera.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& kf : impl_->keyframes) {
    if (kf.id != id) continue;
    impl_->map.transformAnchored(id, T_world_camera * kf.T_world_camera.inverse());
    kf.T_world_camera = T_world_camera;
    return true;
  }
  return false;
}

RenderedView GaussianMapper::render(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const {
  if (!camera.valid()) throw std::invalid_argument("GaussianMapper::render: invalid camera intrinsics");
  if (!T_world_camera.matrix().allFinite()) throw std::invalid_argument("GaussianMapper::render: pose is not finite");
  CameraIntrinsics pinhole = camera;
  pinhole.distortion = {0, 0, 0, 0, 0};
  RenderedView view;
  std::shared_ptr<const cv::Mat> rays;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    impl_->renderPinhole(T_world_camera, pinhole, impl_->render_raster, impl_->view_out);
    if (camera.distorted()) rays = impl_->rays.rays(camera);
    const RenderResult<float>& r = impl_->view_out;
    const std::size_t npix = static_cast<std::size_t>(r.width) * r.height;
    view.bgr.create(r.height, r.width, CV_8UC3);
    view.depth_m.create(r.height, r.width, CV_32FC1);
    view.alpha.create(r.height, r.width, CV_32FC1);
    for (int v = 0; v < r.height; ++v) {
      cv::Vec3b* c = view.bgr.ptr<cv::Vec3b>(v);
      float* d = view.depth_m.ptr<float>(v);
      float* a = view.alpha.ptr<float>(v);
      for (int u = 0; u < r.width; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * r.width + u;
        for (int ch = 0; ch < 3; ++ch) c[u][2 - ch] = cv::saturate_cast<std::uint8_t>(r.color[ch * npix + i] * 255.f + 0.5f);
        a[u] = r.alpha[i];
        d[u] = r.alpha[i] >= 0.5f ? r.depth[i] / r.alpha[i] : 0.f;
      }
    }
  }
  if (rays) {
    // Distorted pixel (u, v) sees ray (x, y, 1): its pinhole pixel is (fx x + cx, fy y + cy).
    cv::Mat map(camera.height, camera.width, CV_32FC2);
    for (int v = 0; v < camera.height; ++v) {
      const cv::Vec2f* ray = rays->ptr<cv::Vec2f>(v);
      cv::Vec2f* m = map.ptr<cv::Vec2f>(v);
      for (int u = 0; u < camera.width; ++u)
        m[u] = cv::Vec2f(static_cast<float>(camera.fx * ray[u][0] + camera.cx), static_cast<float>(camera.fy * ray[u][1] + camera.cy));
    }
    cv::Mat bgr, depth, alpha;
    cv::remap(view.bgr, bgr, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::remap(view.depth_m, depth, map, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
    cv::remap(view.alpha, alpha, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
    view.bgr = bgr;
    view.depth_m = depth;
    view.alpha = alpha;
  }
  return view;
}

cv::Mat GaussianMapper::renderDepth(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const {
  return render(T_world_camera, camera).depth_m;
}

KeyframeEvaluation GaussianMapper::evaluateKeyframes(const std::string& side_by_side_dir) const {
  KeyframeEvaluation ev;
  double depth_sum = 0.0;
  std::size_t depth_n = 0;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const TrainingKeyframe& kf : impl_->keyframes) {
    if (!kf.hasImages()) continue;
    RenderResult<float>& r = impl_->view_out;
    impl_->renderPinhole(kf.T_world_camera, kf.camera, impl_->render_raster, r);
    const std::size_t npix = static_cast<std::size_t>(r.width) * r.height;
    double se = 0.0, se_raw = 0.0;
    std::size_t ns = 0;
    const bool expose = options_.exposure_compensation;
    float gain[3], offset[3];
    for (int ch = 0; ch < 3; ++ch) {
      gain[ch] = expose ? std::exp(kf.exposure[ch]) : 1.f;
      offset[ch] = expose ? kf.exposure[3 + ch] : 0.f;
    }
    cv::Mat rendered(r.height, r.width, CV_8UC3), rdepth(r.height, r.width, CV_32FC1);
    for (int v = 0; v < r.height; ++v) {
      const std::uint8_t* m = kf.static_mask.ptr<std::uint8_t>(v);
      const float* d = kf.depth_m.ptr<float>(v);
      const cv::Vec3b* c = kf.bgr.ptr<cv::Vec3b>(v);
      for (int u = 0; u < r.width; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * r.width + u;
        for (int ch = 0; ch < 3; ++ch) {
          const float raw = std::min(1.f, std::max(0.f, r.color[ch * npix + i]));
          const float x = std::min(1.f, std::max(0.f, gain[ch] * r.color[ch * npix + i] + offset[ch]));
          rendered.at<cv::Vec3b>(v, u)[2 - ch] = static_cast<std::uint8_t>(x * 255.f + 0.5f);
          if (m[u]) {
            const double diff = x - c[u][2 - ch] / 255.0, diff_raw = raw - c[u][2 - ch] / 255.0;
            se += diff * diff;
            se_raw += diff_raw * diff_raw;
          }
        }
        rdepth.at<float>(v, u) = r.depth[i];
        if (m[u]) ++ns;
        if (m[u] && d[u] > 0.f) {
          depth_sum += std::abs(r.depth[i] - d[u]);
          ++depth_n;
        }
      }
    }
    if (ns == 0) continue;
    const double mse = std::max(se / (3.0 * ns), 1e-10);
    ev.psnr_per_keyframe_db.push_back(10.0 * std::log10(1.0 / mse));
    ev.psnr_without_exposure_db += 10.0 * std::log10(1.0 / std::max(se_raw / (3.0 * ns), 1e-10));
    if (!side_by_side_dir.empty()) {
      auto colorize = [&](const cv::Mat& depth) {
        cv::Mat d8, out;
        depth.convertTo(d8, CV_8U, 255.0 / options_.valid_max_depth_m);
        cv::applyColorMap(d8, out, cv::COLORMAP_JET);
        out.setTo(cv::Scalar(0, 0, 0), depth <= 0.f);
        return out;
      };
      cv::Mat input = kf.bgr.clone();
      input.setTo(cv::Scalar(255, 0, 255), kf.static_mask == 0);  // dynamic pixels in magenta
      cv::Mat top, bottom, all;
      cv::hconcat(input, rendered, top);
      cv::hconcat(colorize(kf.depth_m), colorize(rdepth), bottom);
      cv::vconcat(top, bottom, all);
      const std::string path = side_by_side_dir + "/kf_" + std::to_string(kf.id) + ".png";
      if (!cv::imwrite(path, all)) throw std::runtime_error("cannot write '" + path + "' (does the folder exist?)");
    }
  }
  ev.num_keyframes = ev.psnr_per_keyframe_db.size();
  for (double p : ev.psnr_per_keyframe_db) ev.psnr_db += p;
  if (ev.num_keyframes) {
    ev.psnr_db /= ev.num_keyframes;
    ev.psnr_without_exposure_db /= ev.num_keyframes;
  }
  ev.depth_l1_m = depth_n ? depth_sum / depth_n : 0.0;
  return ev;
}

std::vector<GaussianCentre> GaussianMapper::centres() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const GaussianMap& m = impl_->map;
  std::vector<GaussianCentre> out(m.size());
  const float* p = m.data(kParamPosition);
  const float* sh = m.data(kParamSh);
  const int w = m.width(kParamSh);
  for (std::size_t i = 0; i < m.size(); ++i) {
    auto c8 = [&](int ch) {
      const float v = 0.5f + 0.28209479177387814f * sh[w * i + ch];
      return static_cast<std::uint8_t>(std::min(255.f, std::max(0.f, v * 255.f + 0.5f)));
    };
    out[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2], c8(0), c8(1), c8(2)};
  }
  return out;
}

void GaussianMapper::savePly(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  writeFileAtomically(path, [&](std::ostream& os) { writeGaussianPly(os, impl_->map); }, true);
}

std::size_t GaussianMapper::loadPly(const std::string& path, std::string* note) {
  GaussianMap loaded(options_.sh_degree, options_.max_gaussians);  // the map's degree and capacity
  const std::size_t n = readGaussianPly(path, loaded, note);       // throws before touching the map
  std::lock_guard<std::mutex> lock(mutex_);
  impl_->map.clear();
  GaussianInit g;
  for (std::size_t i = 0; i < loaded.size(); ++i) {
    const float* p = loaded.data(kParamPosition) + 3 * i;
    const float* s = loaded.data(kParamLogScale) + 3 * i;
    const float* q = loaded.data(kParamRotation) + 4 * i;
    const int w = loaded.width(kParamSh);
    g.position_w = {p[0], p[1], p[2]};
    g.log_scale = {s[0], s[1], s[2]};
    g.rotation_wxyz = {q[0], q[1], q[2], q[3]};
    g.opacity_logit = loaded.data(kParamOpacity)[i];
    g.sh.assign(loaded.data(kParamSh) + w * i, loaded.data(kParamSh) + w * (i + 1));
    g.anchor_keyframe_id = -1;
    impl_->map.add(g);
  }
  impl_->adam.compact(impl_->map, std::vector<std::uint8_t>());
  impl_->adam.resize(impl_->map);
  impl_->grad_accum.assign(impl_->map.size(), 0.f);
  impl_->grad_count.assign(impl_->map.size(), 0);
  return n;
}

void GaussianMapper::saveCentresPcd(const std::string& path) const {
  const std::vector<GaussianCentre> pts = centres();
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\n"
       << "TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH " << pts.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS "
       << pts.size() << "\nDATA binary\n";
    for (const auto& p : pts) {
      const std::uint32_t rgb = (static_cast<std::uint32_t>(p.r) << 16) | (static_cast<std::uint32_t>(p.g) << 8) | p.b;
      os.write(reinterpret_cast<const char*>(&p.x), 12);
      os.write(reinterpret_cast<const char*>(&rgb), 4);
    }
  }, true);
}

GaussianMapperStats GaussianMapper::stats() const {
  GaussianMapperStats s;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s.num_gaussians = impl_->map.size();
    s.num_keyframes = impl_->keyframes.size();
    for (const auto& kf : impl_->keyframes) s.num_stored_images += kf.hasImages() ? 1 : 0;
    s.iterations = impl_->iterations;
    s.skipped_keyframes = impl_->skipped;
    s.capacity_hits = impl_->capacity_hits;
    s.last_loss = impl_->last_loss;
  }
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    s.queued = queue_.size();
  }
  s.dropped_keyframes = dropped_;
  return s;
}

void GaussianMapper::reset() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.clear();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  impl_->map.clear();
  impl_->keyframes.clear();
  impl_->adam.compact(impl_->map, std::vector<std::uint8_t>());
  impl_->adam.resize(impl_->map);
  impl_->grad_accum.clear();
  impl_->grad_count.clear();
  impl_->refine_order.clear();
}

}  // namespace dypho::mapping
