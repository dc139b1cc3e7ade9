/// GaussianMapper: the thread-safe composition of trainer, worker, renderer, evaluation and files.
#include "dypho/mapping/gaussian_mapper.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <thread>

#include "gaussian_trainer.h"

namespace dypho::mapping {

GaussianMapper::GaussianMapper(const GaussianMapperOptions& options) : options_(options) {
  options_.validate();
  device_ = selectComputeDevice(options_.device, &device_message_);
  trainer_ = std::make_unique<GaussianTrainer>(options_, device_);
  renderer_ = std::make_unique<MapRenderer>(options_.resolvedNumThreads(), device_);
}

GaussianMapper::~GaussianMapper() { stop(); }

void GaussianMapper::report(const std::string& message) const {
  if (!message.empty() && sink_) sink_(message);
}

/// The trainer's lock for a change: on release (still under the lock) the counters stats() reads
/// are refreshed, so stats() never waits for a training iteration.
class GaussianMapper::ChangeLock {
 public:
  explicit ChangeLock(const GaussianMapper& mapper) : mapper_(mapper), lock_(mapper.mutex_) {}
  ~ChangeLock() { mapper_.refreshStats(); }
  ChangeLock(const ChangeLock&) = delete;
  ChangeLock& operator=(const ChangeLock&) = delete;

 private:
  const GaussianMapper& mapper_;
  std::lock_guard<std::mutex> lock_;
};

AddKeyframeResult GaussianMapper::addKeyframe(const Keyframe& keyframe) {
  AddKeyframeResult r;
  const std::string problem = checkKeyframe(keyframe);
  ChangeLock lock(*this);
  if (!problem.empty()) {
    ++trainer_->skipped;
    r.message = "keyframe " + std::to_string(keyframe.id) + " skipped: " + problem;
    return r;
  }
  for (const auto& kf : trainer_->keyframes) {
    if (kf.id == keyframe.id) {
      trainer_->correctKeyframePoses({{keyframe.id, keyframe.T_world_camera}});
      r.added = true;
      r.message = "keyframe " + std::to_string(keyframe.id) + " already in the map: re-anchored to the new pose";
      return r;
    }
  }
  r = trainer_->integrate(keyframe);
  if (!r.added) ++trainer_->skipped;
  return r;
}

void GaussianMapper::reportDeviceFallback() {
  if (fallback_reported_ || trainer_->device_fallback.empty()) return;
  fallback_reported_ = true;
  device_ = ComputeDevice::kCpu;
  device_message_ = trainer_->device_fallback;
  report(device_message_);
}

double GaussianMapper::optimize(int iterations) {
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < iterations; ++i) {
    ChangeLock lock(*this);
    const double l = trainer_->iterate();
    reportDeviceFallback();
    if (l < 0) break;
    sum += l;
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

void GaussianMapper::start(std::size_t queue_capacity, bool live) {
  if (worker_) return;
  live_ = live;
  std::function<bool()> idle;
  if (live && options_.live_train_when_idle) idle = [this] { return idleStep(); };
  worker_ = std::make_unique<MappingWorker>(
      queue_capacity, [this](const MappingJob& job) { runJob(job); }, std::move(idle), options_.trainingPriority());
}

bool GaussianMapper::idleStep() {
  // Called by the worker thread, which may start before worker_ is assigned: no use of worker_
  // here (the worker checks its own stop flag before each idle step).
  if (idle_paused_ || hurry_) return false;
  {
    ChangeLock lock(*this);
    if (trainer_->keyframes.empty()) return false;
  }
  if (liveIteration() < 0) return false;
  // Renders (rviz views, R_d) follow the idle training about once a second.
  const auto now = std::chrono::steady_clock::now();
  if (now - last_idle_snapshot_ > std::chrono::seconds(1)) {
    last_idle_snapshot_ = now;
    std::int64_t done = -1;
    {
      std::lock_guard<std::mutex> lock(snapshot_mutex_);
      done = done_keyframe_id_;
    }
    publishSnapshot(done);
  }
  return true;
}

double GaussianMapper::liveIteration() {
  const auto start = std::chrono::steady_clock::now();
  double loss = -1.0;
  {
    ChangeLock lock(*this);
    loss = trainer_->iterate();
    reportDeviceFallback();
  }
  const double duty = options_.live_cpu_training_duty;
  if (loss >= 0 && duty < 1.0 && device_ == ComputeDevice::kCpu && !hurry_) {
    // Capped, so that a stop or a new job never waits long for the rest to end.
    const auto busy = std::chrono::steady_clock::now() - start;
    const auto rest = std::chrono::duration_cast<std::chrono::steady_clock::duration>(busy * ((1.0 - duty) / duty));
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(rest, std::chrono::milliseconds(250)));
  }
  return loss;
}

void GaussianMapper::runJob(const MappingJob& job) {
  try {
    // Every keyframe is seeded (cheap); a merged job (live, mapping behind) trains as one.
    for (const KeyframeConstPtr& keyframe : job.keyframes) report(addKeyframe(*keyframe).message);
    if (!job.corrections.empty()) applyCorrections(job.corrections);
    if (job.keyframes.empty()) return;
    const int iterations = options_.iterations_per_keyframe * static_cast<int>(job.keyframes.size());
    for (int i = 0; i < iterations && !worker_->stopping() && !hurry_; ++i) {
      // Live: the next job waits, so this keyframe gets fewer iterations (idle time adds more).
      if (live_ && i >= options_.live_min_iterations_per_keyframe && worker_->queued() > 0) break;
      if (live_) {
        liveIteration();
      } else {
        optimize(1);
      }
    }
  } catch (const std::exception& e) {
    report(std::string("mapping worker: ") + e.what());
  }
  if (!job.keyframes.empty()) publishSnapshot(job.keyframes.back()->id);
}

void GaussianMapper::publishSnapshot(std::int64_t keyframe_id) {
  MapSnapshot s;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s.map = std::make_shared<const GaussianMap>(trainer_->hostMap());
    s.iterations = trainer_->iterations;
  }
  s.after_keyframe_id = keyframe_id;
  MapSnapshot previous;  // freed after the lock is released: readers never wait for that
  {
    std::lock_guard<std::mutex> lock(snapshot_mutex_);
    previous = std::move(snapshot_);
    snapshot_ = std::move(s);
    done_keyframe_id_ = std::max(done_keyframe_id_, keyframe_id);
  }
  snapshot_cv_.notify_all();
}

MapSnapshot GaussianMapper::latestSnapshot() const {
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  return snapshot_;
}

MapSnapshot GaussianMapper::waitForSnapshot(std::int64_t keyframe_id) const {
  std::unique_lock<std::mutex> lock(snapshot_mutex_);
  snapshot_cv_.wait(lock, [&] { return !worker_ || worker_->stopping() || done_keyframe_id_ >= keyframe_id; });
  return snapshot_;
}

bool GaussianMapper::enqueueKeyframe(KeyframeConstPtr keyframe, bool block_when_full) {
  if (!keyframe) return false;
  if (worker_) return worker_->push(MappingJob{{std::move(keyframe)}, {}}, block_when_full);
  report(addKeyframe(*keyframe).message);
  optimize(options_.iterations_per_keyframe);
  publishSnapshot(keyframe->id);
  return true;
}

void GaussianMapper::enqueueCorrections(KeyframePoseCorrections corrections, bool block_when_full) {
  if (corrections.empty()) return;
  if (worker_) {
    worker_->push(MappingJob{{}, std::move(corrections)}, block_when_full);
  } else {
    applyCorrections(corrections);
  }
}

std::size_t GaussianMapper::applyCorrections(const KeyframePoseCorrections& corrections) {
  ChangeLock lock(*this);
  const std::size_t n = trainer_->correctKeyframePoses(corrections);
  corrected_ += n;
  return n;
}

void GaussianMapper::waitUntilIdle() {
  if (worker_) worker_->waitUntilIdle();
}

double GaussianMapper::finish(std::optional<double> budget_s) {
  const auto start = std::chrono::steady_clock::now();
  const auto within_budget = [&] {
    return !budget_s || std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < *budget_s;
  };
  idle_paused_ = true;          // the refinement below replaces the idle training
  if (budget_s) hurry_ = true;  // queued keyframes: added to the map, not trained
  waitUntilIdle();
  hurry_ = false;
  struct ResumeIdle {
    std::atomic<bool>& flag;
    ~ResumeIdle() { flag = false; }
  } resume_idle{idle_paused_};
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < options_.final_refine_iterations && within_budget(); ++i) {
    ChangeLock lock(*this);
    const double l = trainer_->iterate(/*all_keyframes=*/true);
    reportDeviceFallback();
    if (l < 0) break;
    sum += l;
    ++n;
  }
  if (options_.exposure_mean_gauge) {
    ChangeLock lock(*this);
    trainer_->centreExposureGauge();
  }
  return n > 0 ? sum / n : 0.0;
}

void GaussianMapper::stop() {
  if (worker_) worker_->stop();
  snapshot_cv_.notify_all();
}

void GaussianMapper::setMessageSink(std::function<void(const std::string&)> sink) { sink_ = std::move(sink); }

bool GaussianMapper::updateKeyframePose(std::int64_t id, const Eigen::Isometry3d& T_world_camera) {
  return applyCorrections({{id, T_world_camera}}) > 0;
}

RenderedView GaussianMapper::render(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return renderer_->render(trainer_->hostMap(), T_world_camera, camera);
}

cv::Mat GaussianMapper::renderDepth(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) const {
  return render(T_world_camera, camera).depth_m;
}

KeyframeEvaluation GaussianMapper::evaluateKeyframes(const std::string& side_by_side_dir,
                                                     std::optional<double> budget_s) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return mapping::evaluateKeyframes(*trainer_, side_by_side_dir, budget_s);
}

std::vector<GaussianCentre> GaussianMapper::centres() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return gaussianCentres(trainer_->hostMap());
}

void GaussianMapper::savePly(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  saveGaussianPly(path, trainer_->hostMap());
}

std::size_t GaussianMapper::loadPly(const std::string& path, std::string* note) {
  // Read first (throws before touching the map), then swap under the lock.
  GaussianMap loaded = loadGaussianPly(path, options_.sh_degree, options_.max_gaussians, note);
  std::size_t count = 0;
  {
    ChangeLock lock(*this);
    GaussianTrainer& t = *trainer_;
    t.map = std::move(loaded);
    t.adam.compact(t.map, std::vector<std::uint8_t>());
    t.adam.resize(t.map);
    t.grad_accum.assign(t.map.size(), 0.f);
    t.grad_count.assign(t.map.size(), 0);
    t.hostChanged();
    count = t.map.size();
  }
  // Views and clouds show the loaded map at once, not after the next keyframe's training (which a
  // localisation-only run never has).
  std::int64_t done = -1;
  {
    std::lock_guard<std::mutex> lock(snapshot_mutex_);
    done = done_keyframe_id_;
  }
  publishSnapshot(done);
  return count;
}

void GaussianMapper::saveCentresPcd(const std::string& path) const { mapping::saveCentresPcd(path, centres()); }

void GaussianMapper::refreshStats() const {
  GaussianMapperStats s;
  const GaussianTrainer& t = *trainer_;
  s.num_gaussians = t.map.size();
  s.num_keyframes = t.keyframes.size();
  for (const auto& kf : t.keyframes) s.num_stored_images += kf.hasImages() ? 1 : 0;
  s.iterations = t.iterations;
  s.skipped_keyframes = t.skipped;
  s.capacity_hits = t.capacity_hits;
  s.last_loss = t.last_loss;
  s.corrected_keyframes = corrected_;
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_ = s;
}

GaussianMapperStats GaussianMapper::stats() const {
  GaussianMapperStats s;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    s = stats_;
  }
  if (worker_) {
    s.queued = worker_->queued();
    s.merged_jobs = worker_->merged();
  }
  return s;
}

KeyframePoseCorrections GaussianMapper::keyframePoses() const {
  std::lock_guard<std::mutex> lock(mutex_);
  KeyframePoseCorrections poses;
  for (const auto& kf : trainer_->keyframes) poses.emplace_back(kf.id, kf.T_world_camera);
  return poses;
}

void GaussianMapper::reset() {
  if (worker_) worker_->clear();
  {
    ChangeLock lock(*this);
    trainer_->clear();
  }
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  snapshot_ = MapSnapshot();
}

}  // namespace dypho::mapping
