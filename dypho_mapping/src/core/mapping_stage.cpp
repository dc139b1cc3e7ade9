/// MappingStage: Gaussian map + keyframe cloud with the queue, R_d and refinement policy.
#include "dypho/mapping/mapping_stage.h"

#include <ostream>
#include <stdexcept>

#include "dypho/common/atomic_file.h"
#include "dypho/mapping/gaussian_map_io.h"

namespace dypho::mapping {

MappingStage::MappingStage(const MappingOptions& options, MappingMode mode, const MappingStageOptions& stage)
    : mode_(mode),
      stage_options_(stage),
      gaussians_(options.gaussian),
      cloud_(options.cloud),
      motion_(stage.motion_max_gap_s),
      depth_renderer_(1, gaussians_.computeDevice()),
      view_renderer_(1, gaussians_.computeDevice()) {
  options.validate();
  if (stage.keyframe_queue_size < 1) throw std::invalid_argument("keyframe_queue_size must be >= 1");
  gaussians_.start(static_cast<std::size_t>(stage.keyframe_queue_size), mode == MappingMode::kLive);
}

MappingStage::~MappingStage() { gaussians_.stop(); }

bool MappingStage::addKeyframe(KeyframeConstPtr keyframe) {
  if (!keyframe) return true;
  std::int64_t previous = -1;
  {
    std::lock_guard<std::mutex> lock(cloud_mutex_);
    cloud_.addKeyframe(*keyframe);  // cheap (strided unprojection)
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    previous = newest_keyframe_id_;
    newest_keyframe_id_ = keyframe->id;
    ++counters_.keyframes_received;
  }
  const bool deterministic = mode_ == MappingMode::kDeterministic;
  const bool own_job = gaussians_.enqueueKeyframe(std::move(keyframe), /*block_when_full=*/deterministic);
  if (deterministic && previous >= 0) {
    // R_d from the map after the previous keyframe's job: the worker trains this one meanwhile.
    MapSnapshot snapshot = gaussians_.waitForSnapshot(previous);
    std::lock_guard<std::mutex> lock(mutex_);
    render_snapshot_ = std::move(snapshot);
  }
  return own_job;
}

void MappingStage::correctKeyframes(const KeyframePoseCorrections& corrections) {
  if (corrections.empty()) return;
  {
    std::lock_guard<std::mutex> lock(cloud_mutex_);
    for (const auto& [id, T_world_camera] : corrections) cloud_.updateKeyframePose(id, T_world_camera);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.correction_batches;
  }
  gaussians_.enqueueCorrections(corrections, /*block_when_full=*/mode_ == MappingMode::kDeterministic);
}

void MappingStage::observePose(const PoseUpdate& update) {
  if (update.restarted) reset();  // a new world: the old map does not belong to it
  std::lock_guard<std::mutex> lock(mutex_);
  // A pose not anchored to the map must not predict where to render the map from.
  PoseUpdate for_map = update;
  for_map.trusted = update.trusted && update.anchored;
  motion_.observe(for_map);
}

std::optional<Timestamp> MappingStage::expectedNextStamp() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!motion_.hasVelocity()) return std::nullopt;
  return motion_.lastStamp() + motion_.stepNs();
}

cv::Mat MappingStage::predictedDepth(Timestamp stamp_ns, const CameraIntrinsics& camera) {
  std::optional<Eigen::Isometry3d> T_world_predicted;
  MapSnapshot snapshot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    T_world_predicted = motion_.predict(stamp_ns);
    snapshot = mode_ == MappingMode::kDeterministic ? render_snapshot_ : gaussians_.latestSnapshot();
  }
  if (!T_world_predicted || !snapshot.map || snapshot.map->size() == 0 || !camera.valid()) return cv::Mat();
  cv::Mat depth;
  {
    std::lock_guard<std::mutex> lock(depth_render_mutex_);
    depth = depth_renderer_.renderDepth(snapshot.map, *T_world_predicted, camera);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.predicted_depth_rendered;
  counters_.render_snapshot_keyframe = snapshot.after_keyframe_id;
  return depth;
}

std::pair<Timestamp, cv::Mat> MappingStage::predictedDepthForNextFrame(const CameraIntrinsics& camera) {
  const std::optional<Timestamp> next_ns = expectedNextStamp();
  if (!next_ns) return {0, cv::Mat()};
  return {*next_ns, predictedDepth(*next_ns, camera)};
}

RenderedView MappingStage::renderView(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) {
  const MapSnapshot snapshot = gaussians_.latestSnapshot();
  if (!snapshot.map || snapshot.map->size() == 0 || !camera.valid()) return RenderedView();
  std::lock_guard<std::mutex> lock(view_render_mutex_);
  return view_renderer_.render(snapshot.map, T_world_camera, camera);
}

double MappingStage::finish(std::optional<double> budget_s) {
  std::int64_t received = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    received = static_cast<std::int64_t>(counters_.keyframes_received);
    if (received == refined_after_keyframes_) return 0.0;  // nothing new since the last refinement
  }
  const double loss = gaussians_.finish(budget_s);
  std::lock_guard<std::mutex> lock(mutex_);
  refined_after_keyframes_ = received;
  return loss;
}

std::vector<std::string> MappingStage::save(const std::string& dir, bool refine, std::optional<double> budget_s) {
  if (refine) finish(budget_s);
  const std::vector<std::string> paths{dir + "/map.ply", dir + "/map.pcd", dir + "/gaussian_centres.pcd"};
  gaussians_.savePly(paths[0]);
  {
    std::lock_guard<std::mutex> lock(cloud_mutex_);
    cloud_.savePcd(paths[1]);
  }
  gaussians_.saveCentresPcd(paths[2]);
  return paths;
}

KeyframeEvaluation MappingStage::writeEvaluation(const std::string& dir, std::optional<double> budget_s) {
  const KeyframeEvaluation eval = gaussians_.evaluateKeyframes("", budget_s);
  const MappingStageStats counts = stats();
  writeFileAtomically(dir + "/" + kEvaluationFile, [&](std::ostream& os) {
    os << "psnr_db: " << eval.psnr_db << "\nkeyframes: " << eval.num_keyframes
       << "\nkeyframes_stored: " << eval.num_keyframes_stored << "\ndepth_l1_m: " << eval.depth_l1_m
       << "\nkeyframes_received: " << counts.keyframes_received
       << "\nkeyframes_in_map: " << counts.gaussians.num_keyframes << "\nmerged_jobs: " << counts.gaussians.merged_jobs
       << "\n";
  });
  return eval;
}

std::size_t MappingStage::loadMap(const std::string& path, std::string* note) { return gaussians_.loadPly(path, note); }

void MappingStage::reset() {
  gaussians_.reset();
  {
    std::lock_guard<std::mutex> lock(cloud_mutex_);
    cloud_.reset();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  motion_.reset();
  newest_keyframe_id_ = -1;
  render_snapshot_ = MapSnapshot();
  refined_after_keyframes_ = -1;
}

MappingStageStats MappingStage::stats() const {
  MappingStageStats s;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s = counters_;
  }
  s.gaussians = gaussians_.stats();
  return s;
}

KeyframeCloudMap::Cloud::Ptr MappingStage::buildCloud() const {
  KeyframeCloudSnapshot snapshot;
  {
    std::lock_guard<std::mutex> lock(cloud_mutex_);
    snapshot = cloud_.snapshot();  // poses and shared points: no point copied under the lock
  }
  return mapping::buildCloud(snapshot);
}

std::optional<std::vector<GaussianCentre>> MappingStage::latestGaussianCentres() const {
  const MapSnapshot snapshot = gaussians_.latestSnapshot();
  if (!snapshot.map) return std::nullopt;
  return mapping::gaussianCentres(*snapshot.map);
}

std::size_t MappingStage::numCloudPoints() const {
  std::lock_guard<std::mutex> lock(cloud_mutex_);
  return cloud_.numPoints();
}

}  // namespace dypho::mapping
