/// GaussianMappingNodelet: keyframes, keyframe correction batches and tracking status in; the 3D
/// Gaussian map and the keyframe point cloud out. All the work and its policy are in
/// dypho::mapping::MappingStage (kLive: a full queue drops the oldest waiting keyframe, counted;
/// R_d and views are rendered from map snapshots, outside the map's lock), the same stage the
/// in-process pipeline runs. Renders run on this nodelet's own threads, so no ROS callback waits
/// for the optimiser: R_d at normal priority (the mask waits for it), the views for viewers at the
/// training's nice value. The clouds are built and published on a cloud thread of their own at
/// the training's nice value: the voxel filter over every keyframe grows with the map and must
/// neither hold a callback thread of the manager nor take a core from the camera-rate threads.
///
/// Outputs: rendered/color (bgr8) and rendered/depth (32FC1 m) at the latest tracked pose, at
/// ~rendered_scale of the input resolution;
/// rendered/depth_predicted (32FC1 m, R_d) at the constant-velocity prediction of the next frame's
/// pose, at the mask's working resolution (~predicted_depth_scale), header stamp = the expected
/// stamp of that frame; gaussian_cloud (XYZRGB Gaussian centres) and map_cloud (keyframe points).
/// Services: ~save_map (final refinement first with ~refine_before_save), ~load_map, ~reset,
/// and the map half of a session (session_folder.h): ~save_session writes session/map.ply and
/// completes the session when the tracking nodelet's tracker.bin is there (the tracking
/// nodelet's ~save_session calls it); ~load_session and ~session load a session's map.

#include <atomic>
#include <chrono>
#include <filesystem>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dypho_slam/Keyframe.h>
#include <dypho_slam/KeyframeCorrections.h>
#include <dypho_slam/LoadMap.h>
#include <dypho_slam/Reset.h>
#include <dypho_slam/SaveMap.h>
#include <dypho_slam/TrackingStatus.h>
#include <nodelet/nodelet.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pluginlib/class_list_macros.hpp>
#include <sensor_msgs/PointCloud2.h>

#include "dypho/common/output_path.h"
#include "dypho/common/thread_budget.h"
#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/mapping_options_fields.h"
#include "dypho/mapping/mapping_stage.h"
#include "dypho/mapping/rasterizer.h"
#include "dypho/pipeline/session_folder.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/nodelet_runtime.h"
#include "dypho_ros/param_reader.h"

namespace dypho::mapping_ros {

namespace rc = dypho::ros_conversions;

/// Frames, rates and queues of the nodelet (not part of the core options).
struct MappingRosParams {
  std::string map_frame = "map";  ///< frame of the published clouds (the tracking world frame)
  double publish_period_s = 1.0;  ///< cloud publication period [s] (only with subscribers), > 0
  double render_period_s = 0.2;   ///< minimum interval of rendered/color and rendered/depth [s]
  /// rendered/color and rendered/depth at this fraction of the input resolution, (0, 1]; below 1
  /// for a viewer on another host (0.5 = a quarter of the bytes)
  double rendered_scale = 1.0;
  int keyframe_queue_size = 8;  ///< jobs waiting for the worker; beyond it a new job joins the newest waiting one
  /// R_d is rendered at this fraction of the input resolution: the mask's background_scale
  double predicted_depth_scale = 0.5;
  /// where save_map writes (requests name folders inside it) and the map is saved on shutdown
  /// (empty: $ROS_HOME/dypho, default ~/.ros/dypho, resolved at start-up)
  std::string output_dir;
  std::string map_load_path;  ///< 3DGS PLY loaded at start-up (empty: start with an empty map)
  /// A saved session whose map is loaded at start-up (a session folder or a run's output folder
  /// holding session/; the tracking nodelet restores its tracker half). Empty: none.
  std::string session;
  /// Localisation in a loaded map (the tracking nodelet's localization_only): a restart (time
  /// jumped back) keeps the map, and no session is saved on shutdown (it did not change).
  bool localization_only = false;
  /// save_map first runs the mapper's final refinement (`final_refine_iterations` over all
  /// keyframes, GaussianMapper::finish(); blocks the call for that long, mapping goes on beside it)
  bool refine_before_save = true;
  /// Wall time the final refinement may take when the nodelet shuts down (and saves the map)
  /// [s]: queued keyframes are added untrained, refinement stops at the budget, then the files
  /// are written. Default 6: roslaunch escalates to SIGTERM 15 s after Ctrl-C, and tracking's
  /// trajectory is written after the map. > 0.
  double shutdown_refine_budget_s = 6.0;
  /// Wall time map_evaluation.txt may take when the nodelet shuts down [s]: no keyframe is
  /// rendered for it after that (keyframes taken spread over the run; the file says how many of
  /// the stored ones). Default 2: unbounded, 53 keyframes took 7-8 s on a loaded 2-core machine,
  /// and the manager stops its nodelets one at a time, so tracking's final global BA and
  /// trajectory.txt could come after roslaunch's SIGTERM. > 0.
  double shutdown_evaluation_budget_s = 2.0;
  /// Cores of the thread budget (thread_budget.h; 0 = every core): with num_threads 0 the
  /// rasterizer/optimiser pool gets them all, at the lower priority of training_nice.
  int cores = 0;
};

/// A pose to render at (the latest tracked pose).
struct RenderRequest {
  Eigen::Isometry3d T_world_camera;
  ros::Time stamp;
};

class GaussianMappingNodelet : public nodelet::Nodelet {
 public:
  /// Shutdown order (nodelet_runtime.h): diagnostics, the render and cloud threads, then the map
  /// is saved (a bounded final refinement first) with map_evaluation.txt.
  ~GaussianMappingNodelet() override {
    if (session_services_) session_services_->stop();
    if (diagnostics_) diagnostics_->stop();
    {
      std::lock_guard<std::mutex> lock(render_mutex_);
      stop_ = true;
    }
    render_cv_.notify_all();
    cloud_cv_.notify_all();
    if (predict_thread_.joinable()) predict_thread_.join();
    if (view_thread_.joinable()) view_thread_.join();
    if (cloud_thread_.joinable()) cloud_thread_.join();
    if (!stage_) return;
    const mapping::MappingStageStats stats = stage_->stats();
    rc::saveOnShutdown(
        getName(), params_.output_dir, stats.keyframes_received == 0 && stats.gaussians.num_gaussians == 0,
        "no keyframe and no Gaussian", [&] {
          stage_->save(params_.output_dir, params_.refine_before_save, params_.shutdown_refine_budget_s);
          const mapping::KeyframeEvaluation eval =
              stage_->writeEvaluation(params_.output_dir, params_.shutdown_evaluation_budget_s);
          NODELET_INFO_STREAM("map PSNR " << eval.psnr_db << " dB on static pixels of " << eval.num_keyframes << " of "
                                          << eval.num_keyframes_stored << " keyframes (map_evaluation.txt)");
        });
    // The map half of the session (also a loaded map that got no keyframe: see tracking).
    rc::saveOnShutdown(getName(), params_.output_dir,
                       params_.localization_only || stage_->stats().gaussians.num_gaussians == 0,
                       "no session (localization_only, or no Gaussian)",
                       [&] { NODELET_INFO_STREAM(saveSessionHalf(pipeline::sessionFolderIn(params_.output_dir))); });
  }

  /// The nodelet's parameters into params_, the core's returned (validated, thread budget
  /// applied); throws on a bad one.
  mapping::MappingOptions readParameters(ros::NodeHandle& pnh) {
    rc::RosParamReader reader(pnh);
    mapping::MappingOptions options;
    mapping::visitOptions(options, reader);
    reader("map_frame", params_.map_frame, "");
    reader("publish_period_s", params_.publish_period_s, "");
    reader("render_period_s", params_.render_period_s, "");
    reader("rendered_scale", params_.rendered_scale, "");
    if (!(params_.rendered_scale > 0 && params_.rendered_scale <= 1)) {
      throw std::invalid_argument("~rendered_scale must be in (0, 1]");
    }
    reader("keyframe_queue_size", params_.keyframe_queue_size, "");
    reader("predicted_depth_scale", params_.predicted_depth_scale, "");
    reader("output_dir", params_.output_dir, "");
    reader("map_load_path", params_.map_load_path, "");
    reader("session", params_.session, "");
    reader("localization_only", params_.localization_only, "");
    if (!params_.session.empty() && !params_.map_load_path.empty()) {
      throw std::invalid_argument("~session and ~map_load_path are both set: a session brings its own map, set one");
    }
    reader("refine_before_save", params_.refine_before_save, "");
    reader("shutdown_refine_budget_s", params_.shutdown_refine_budget_s, "");
    reader("shutdown_evaluation_budget_s", params_.shutdown_evaluation_budget_s, "");
    reader("cores", params_.cores, "");
    if (!(params_.shutdown_refine_budget_s > 0)) throw std::invalid_argument("~shutdown_refine_budget_s must be > 0");
    if (!(params_.shutdown_evaluation_budget_s > 0)) {
      throw std::invalid_argument("~shutdown_evaluation_budget_s must be > 0");
    }
    if (!(params_.publish_period_s > 0)) throw std::invalid_argument("~publish_period_s must be > 0");
    reader.checkNoUnknownKeys();
    // Empty output_dir: $ROS_HOME/dypho (~/.ros/dypho); the shutdown save writes there.
    std::string output_warning;
    params_.output_dir = rc::prepareOutputDirectory(params_.output_dir, output_warning);
    if (!output_warning.empty()) NODELET_WARN_STREAM(output_warning << ": set ~output_dir to keep the map");
    options.validate();
    if (options.gaussian.num_threads == 0)
      options.gaussian.num_threads = planThreadBudget(params_.cores).mapping_threads;
    NODELET_INFO_STREAM("mapping parameters:"
                        << reader.summary() << "\noutputs go to " << params_.output_dir
                        << "\nthread budget: " << options.gaussian.num_threads << " training threads at nice +"
                        << options.gaussian.training_nice
                        << (options.gaussian.training_idle_class ? " in the idle class (SCHED_IDLE)" : "")
                        << (options.gaussian.live_train_when_idle ? ", training while idle" : ""));
    return options;
  }

  void onInit() override {
    rc::startOrStayIdle(getName(), [this] { start(); });
  }

  void start() {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    // 1. Parameters.
    const mapping::MappingOptions options = readParameters(pnh);

    // 2. Cores and threads.
    mapping::MappingStageOptions stage_options;
    stage_options.keyframe_queue_size = params_.keyframe_queue_size;
    stage_ = std::make_unique<mapping::MappingStage>(options, mapping::MappingMode::kLive, stage_options);
    stage_->gaussians().setMessageSink([this](const std::string& m) { NODELET_WARN_STREAM_THROTTLE(5.0, m); });
    NODELET_INFO_STREAM(
        stage_->gaussians().deviceMessage()
        << (stage_->gaussians().computeDevice() == mapping::ComputeDevice::kCpu
                ? std::string("; CPU tile kernels: ") + (mapping::rasterAvx2Available() ? "avx2" : "generic")
                : std::string()));
    if (!params_.map_load_path.empty()) {
      // A bad file is reported and mapping starts empty (the nodelet manager keeps running).
      const LoadOutcome r = loadMap(params_.map_load_path);
      if (r.success) {
        NODELET_INFO_STREAM(r.message);
      } else {
        NODELET_ERROR_STREAM("~map_load_path: " << r.message << "; starting with an empty map");
      }
    }
    start_time_ = std::filesystem::file_time_type::clock::now();
    if (!params_.session.empty()) {
      // A session that cannot be loaded leaves the nodelet idle with the reason (see tracking).
      const LoadOutcome r = loadSessionMap(params_.session);
      if (!r.success) throw std::runtime_error("~session: " + r.message);
      NODELET_INFO_STREAM("~session: " << r.message);
    }
    predict_thread_ = std::thread([this] { predictLoop(); });
    view_thread_ = std::thread([this, nice = options.gaussian.training_nice] { viewLoop(nice); });

    // 3. Outputs.
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
    gaussian_cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("gaussian_cloud", 1, true);
    color_pub_ = nh.advertise<sensor_msgs::Image>("rendered/color", 1);
    depth_pub_ = nh.advertise<sensor_msgs::Image>("rendered/depth", 1);
    predicted_pub_ = nh.advertise<sensor_msgs::Image>("rendered/depth_predicted", 1);
    save_srv_ = pnh.advertiseService("save_map", &GaussianMappingNodelet::onSave, this);
    reset_srv_ = pnh.advertiseService("reset", &GaussianMappingNodelet::onReset, this);
    load_srv_ = pnh.advertiseService("load_map", &GaussianMappingNodelet::onLoad, this);
    // Own queue and thread: the tracking nodelet calls these from its session services, which
    // must not wait for a manager thread.
    session_services_ = std::make_unique<rc::OwnThreadServices>(pnh);
    session_services_->advertise("save_session", &GaussianMappingNodelet::onSaveSession, this);
    session_services_->advertise("load_session", &GaussianMappingNodelet::onLoadSession, this);
    session_services_->start();
    cloud_thread_ = std::thread([this, nice = options.gaussian.training_nice] { cloudLoop(nice); });
    diagnostics_ = std::make_unique<rc::NodeletDiagnostics>(
        nh, pnh, getName(), "mapping", [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); });

    // 4. Inputs.
    keyframe_sub_ = nh.subscribe("keyframe", 10, &GaussianMappingNodelet::onKeyframe, this);
    corrections_sub_ = nh.subscribe("keyframe_corrections", 100, &GaussianMappingNodelet::onCorrections, this);
    status_sub_ = nh.subscribe("tracking_status", 20, &GaussianMappingNodelet::onTrackingStatus, this);
  }

 private:
  void onKeyframe(const dypho_slam::KeyframeConstPtr& msg) {
    try {
      auto keyframe = std::make_shared<Keyframe>(rc::toKeyframe(*msg));
      {
        std::lock_guard<std::mutex> lock(render_mutex_);
        camera_ = keyframe->frame.camera;
        frame_id_ = msg->header.frame_id;
      }
      if (!stage_->addKeyframe(std::move(keyframe))) {
        NODELET_WARN_STREAM_THROTTLE(10.0, "Gaussian mapping is behind: the keyframe joined a waiting job ("
                                               << stage_->stats().gaussians.merged_jobs << " merges so far); "
                                               << "every keyframe is seeded, training is shared out");
      }
      changed_ = true;
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM_THROTTLE(5.0, "skipping keyframe " << msg->id << ": " << e.what());
    }
  }

  void onCorrections(const dypho_slam::KeyframeCorrectionsConstPtr& msg) {
    stage_->correctKeyframes(rc::toCorrections(*msg));
    changed_ = true;
  }

  void onTrackingStatus(const dypho_slam::TrackingStatusConstPtr& msg) {
    PoseUpdate update = rc::toPoseUpdate(*msg);
    if (update.restarted && params_.localization_only) {
      NODELET_WARN_STREAM("tracking restarted (time went backwards): the loaded map is kept (localization_only)");
      update.restarted = false;  // still discontinuous: no velocity across the jump
    } else if (update.restarted) {
      NODELET_WARN_STREAM("tracking restarted (time went backwards): the map is cleared");
    }
    stage_->observePose(update);
    if (update.restarted) changed_ = true;
    if (!update.trusted) return;
    {
      std::lock_guard<std::mutex> lock(render_mutex_);
      predict_request_ = RenderRequest{update.T_world_camera, msg->header.stamp};
      view_request_ = predict_request_;
    }
    render_cv_.notify_all();
  }

  /// What a render thread takes: the newest request (older ones are superseded) with the camera.
  struct RenderJob {
    RenderRequest request;
    CameraIntrinsics camera;
    std::string frame_id;
  };

  /// Waits for a request in `slot` and takes it; nullopt when the nodelet stops.
  std::optional<RenderJob> takeRequest(std::optional<RenderRequest>* slot) {
    std::unique_lock<std::mutex> lock(render_mutex_);
    render_cv_.wait(lock, [&] { return stop_ || slot->has_value(); });
    if (stop_) return std::nullopt;
    RenderJob job{**slot, camera_, frame_id_};
    slot->reset();
    return job;
  }

  /// Predicted-depth thread: R_d for the mask (when it subscribes), at normal priority: the mask
  /// waits for it.
  void predictLoop() {
    nameCurrentThread("dypho_predict");
    while (const std::optional<RenderJob> job = takeRequest(&predict_request_)) {
      if (!job->camera.valid() || predicted_pub_.getNumSubscribers() == 0) continue;
      try {
        const auto [stamp_ns, depth] =
            stage_->predictedDepthForNextFrame(scaledCamera(job->camera, params_.predicted_depth_scale));
        if (depth.empty()) continue;
        std_msgs::Header header;
        header.stamp = rc::toRosTime(stamp_ns);
        header.frame_id = job->frame_id;
        predicted_pub_.publish(rc::toImageMsg(depth, "32FC1", header));
      } catch (const std::exception& e) {
        NODELET_ERROR_STREAM_THROTTLE(5.0, "rendering the predicted depth failed: " << e.what());
      }
    }
  }

  /// View thread: rendered/color and rendered/depth for viewers, every render_period_s at most.
  /// Niced like the cloud thread: on a machine without an idle core a viewer never takes CPU from
  /// the mask or tracking (the views then come less often).
  void viewLoop(int nice_increment) {
    nameCurrentThread("dypho_render");
    const std::string failed = lowerCurrentThreadPriority(ThreadPriority{nice_increment, false});
    if (!failed.empty()) NODELET_WARN_STREAM("view thread keeps its priority: " << failed);
    ros::WallTime last_view = ros::WallTime(0);
    while (const std::optional<RenderJob> job = takeRequest(&view_request_)) {
      const bool want_view = color_pub_.getNumSubscribers() > 0 || depth_pub_.getNumSubscribers() > 0;
      if (!job->camera.valid() || !want_view || (ros::WallTime::now() - last_view).toSec() < params_.render_period_s) {
        continue;
      }
      try {
        last_view = ros::WallTime::now();
        const CameraIntrinsics& camera = job->camera;
        const mapping::RenderedView v =
            stage_->renderView(job->request.T_world_camera,
                               params_.rendered_scale < 1 ? scaledCamera(camera, params_.rendered_scale) : camera);
        if (v.bgr.empty()) continue;
        std_msgs::Header header;
        header.stamp = job->request.stamp;
        header.frame_id = job->frame_id;
        color_pub_.publish(rc::toImageMsg(v.bgr, "bgr8", header));
        depth_pub_.publish(rc::toImageMsg(v.depth_m, "32FC1", header));
      } catch (const std::exception& e) {
        NODELET_ERROR_STREAM_THROTTLE(5.0, "rendering failed: " << e.what());
      }
    }
  }

  /// Cloud thread: every publish_period_s, the clouds (when they changed and someone listens).
  /// Niced like training, but not in the idle class: under a load that leaves no idle core the
  /// map still shows, at about a tenth of a core's share.
  void cloudLoop(int nice_increment) {
    nameCurrentThread("dypho_cloud");
    const std::string failed = lowerCurrentThreadPriority(ThreadPriority{nice_increment, false});
    if (!failed.empty()) NODELET_WARN_STREAM("cloud thread keeps its priority: " << failed);
    const auto period = std::chrono::duration<double>(params_.publish_period_s);
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(render_mutex_);
        if (cloud_cv_.wait_for(lock, period, [&] { return stop_; })) return;
      }
      try {
        publishClouds();
      } catch (const std::exception& e) {
        NODELET_ERROR_STREAM_THROTTLE(5.0, "publishing the map clouds failed: " << e.what());
      }
    }
  }

  void publishClouds() {
    const std::int64_t iterations = stage_->stats().gaussians.iterations;  // the optimiser changes the map too
    if (!changed_ && iterations == last_iterations_) return;
    changed_ = false;
    last_iterations_ = iterations;
    if (cloud_pub_.getNumSubscribers() > 0) {
      auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
      pcl::toROSMsg(*stage_->buildCloud(), *msg);
      msg->header.frame_id = params_.map_frame;
      msg->header.stamp = ros::Time::now();
      cloud_pub_.publish(msg);
    }
    // From the latest snapshot, which never waits for training; before the first snapshot of
    // this world there is nothing to show yet (not an empty map): tried again next period.
    const std::optional<std::vector<mapping::GaussianCentre>> centres =
        gaussian_cloud_pub_.getNumSubscribers() > 0 ? stage_->latestGaussianCentres() : std::nullopt;
    if (gaussian_cloud_pub_.getNumSubscribers() > 0 && !centres) changed_ = true;
    if (centres) {
      pcl::PointCloud<pcl::PointXYZRGB> cloud;
      for (const mapping::GaussianCentre& c : *centres) {
        pcl::PointXYZRGB p(c.r, c.g, c.b);
        p.x = c.x;
        p.y = c.y;
        p.z = c.z;
        cloud.push_back(p);
      }
      auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
      pcl::toROSMsg(cloud, *msg);
      msg->header.frame_id = params_.map_frame;
      msg->header.stamp = ros::Time::now();
      gaussian_cloud_pub_.publish(msg);
    }
  }

  bool onSave(dypho_slam::SaveMap::Request& req, dypho_slam::SaveMap::Response& res) {
    try {
      // Only under the output directory: a ROS 1 service can be called by anyone on the network.
      const std::string dir = resolveOutputDirectory(rc::outputBaseDirectory(params_.output_dir), req.directory);
      std::filesystem::create_directories(dir);
      res.files = stage_->save(dir, params_.refine_before_save);
      const mapping::KeyframeEvaluation eval = stage_->writeEvaluation(dir);
      res.files.push_back(dir + "/" + mapping::MappingStage::kEvaluationFile);
      const mapping::MappingStageStats stats = stage_->stats();
      res.success = true;
      res.message = "wrote " + std::to_string(stats.gaussians.num_gaussians) + " Gaussians and " +
                    std::to_string(stats.keyframes_received) + " keyframe clouds to " + res.files.front() +
                    "; map PSNR " + std::to_string(eval.psnr_db) + " dB on static pixels of " +
                    std::to_string(eval.num_keyframes) + " keyframes";
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    return true;
  }

  struct LoadOutcome {
    bool success = false;
    std::string message;
  };

  /// Replaces the Gaussian map with the PLY at `path` (the worker keeps running; the mapper swaps
  /// the map under its lock). On error the current map is kept.
  LoadOutcome loadMap(const std::string& path) {
    LoadOutcome r;
    if (path.empty()) {
      r.message = "no path given (expected a 3DGS .ply, e.g. the map.ply written by ~save_map)";
      return r;
    }
    try {
      std::string note;
      const std::size_t n = stage_->loadMap(path, &note);
      r.success = true;
      r.message = "loaded " + std::to_string(n) + " Gaussians from " + path + (note.empty() ? "" : " (" + note + ")");
      changed_ = true;
    } catch (const std::exception& e) {
      r.message = std::string(e.what()) + "; the current map is kept";
    }
    return r;
  }

  bool onLoad(dypho_slam::LoadMap::Request& req, dypho_slam::LoadMap::Response& res) {
    const LoadOutcome r = loadMap(req.path);
    res.success = r.success;
    res.message = r.message;
    if (r.success) {
      NODELET_INFO_STREAM(r.message);
    } else {
      NODELET_WARN_STREAM("load_map: " << r.message);
    }
    return true;
  }

  /// The map half of the session at `path` (a session folder or a run's output folder), checked
  /// against its manifest, replaces the map.
  LoadOutcome loadSessionMap(const std::string& path) {
    try {
      const std::string dir = pipeline::resolveSessionDir(path);
      const pipeline::SessionManifest m =
          pipeline::readSessionManifest(pipeline::sessionFile(dir, pipeline::kSessionManifestFile));
      return loadMap(pipeline::checkedSessionMap(dir, m));
    } catch (const std::exception& e) {
      return LoadOutcome{false, std::string(e.what()) + "; the current map is kept"};
    }
  }

  /// Writes `dir`/map.ply (the map as it stands, no refinement: a session save is quick) and
  /// completes the session when tracker.bin is there; returns what happened. Throws on a write
  /// error.
  std::string saveSessionHalf(const std::string& dir) {
    pipeline::beginSessionSave(dir);
    const std::string map_path = pipeline::sessionFile(dir, pipeline::kSessionMapFile);
    stage_->gaussians().savePly(map_path);
    std::string why;
    if (pipeline::completeSession(dir, start_time_, "ROS graph (" + getName() + ")", &why)) {
      return "session saved to " + dir;
    }
    return "map half of the session written to " + dir + "; the tracking nodelet completes it (" + why + ")";
  }

  bool onSaveSession(dypho_slam::SaveMap::Request& req, dypho_slam::SaveMap::Response& res) {
    try {
      const std::string dir =
          pipeline::sessionFolderIn(resolveOutputDirectory(rc::outputBaseDirectory(params_.output_dir), req.directory));
      res.message = saveSessionHalf(dir);
      res.files.push_back(pipeline::sessionFile(dir, pipeline::kSessionMapFile));
      res.success = true;
    } catch (const std::exception& e) {
      res.success = false;
      res.message = std::string("map half of the session not saved: ") + e.what();
    }
    return true;
  }

  bool onLoadSession(dypho_slam::LoadMap::Request& req, dypho_slam::LoadMap::Response& res) {
    const LoadOutcome r = loadSessionMap(req.path);
    res.success = r.success;
    res.message = r.message;
    if (r.success) {
      NODELET_INFO_STREAM("load_session: " << r.message);
    } else {
      NODELET_WARN_STREAM("load_session: " << r.message);
    }
    return true;
  }

  /// /diagnostics: training rate, map size and the keyframe queue.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
    const mapping::MappingStageStats s = stage_->stats();
    const ros::WallTime now = ros::WallTime::now();
    double iterations_per_s = 0.0;
    if (last_diagnosis_.toSec() > 0) {
      const double dt = (now - last_diagnosis_).toSec();
      if (dt > 0) iterations_per_s = static_cast<double>(s.gaussians.iterations - iterations_at_last_diagnosis_) / dt;
    }
    const std::size_t merged_now = s.gaussians.merged_jobs - merged_at_last_diagnosis_;
    last_diagnosis_ = now;
    iterations_at_last_diagnosis_ = s.gaussians.iterations;
    merged_at_last_diagnosis_ = s.gaussians.merged_jobs;
    if (merged_now > 0) {
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                    "%zu jobs merged since the last report: mapping is behind (keyframes seeded, training shared)",
                    merged_now);
    } else if (s.keyframes_received == 0) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "waiting for the first keyframe");
    } else {
      stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "training");
    }
    stat.add("iterations per second", iterations_per_s);
    stat.add("iterations", s.gaussians.iterations);
    stat.add("Gaussians", s.gaussians.num_gaussians);
    stat.add("keyframes received", s.keyframes_received);
    stat.add("keyframes in the map", s.gaussians.num_keyframes);
    stat.add("keyframes with images", s.gaussians.num_stored_images);
    stat.add("jobs queued", s.gaussians.queued);
    stat.add("jobs merged (mapping behind)", s.gaussians.merged_jobs);
    stat.add("keyframes skipped", s.gaussians.skipped_keyframes);
    stat.add("last loss", s.gaussians.last_loss);
  }

  bool onReset(dypho_slam::Reset::Request&, dypho_slam::Reset::Response& res) {
    stage_->reset();
    changed_ = true;
    res.success = true;
    res.message = "map cleared";
    return true;
  }

  MappingRosParams params_;
  std::unique_ptr<mapping::MappingStage> stage_;
  std::atomic<bool> changed_{false};
  std::int64_t last_iterations_ = -1;  ///< cloud thread only
  // Render thread state (render_mutex_).
  std::mutex render_mutex_;
  std::condition_variable render_cv_;
  std::condition_variable cloud_cv_;              ///< wakes the cloud thread to stop (with render_mutex_)
  std::optional<RenderRequest> predict_request_;  ///< for predictLoop
  std::optional<RenderRequest> view_request_;     ///< for viewLoop
  CameraIntrinsics camera_;
  std::string frame_id_;
  bool stop_ = false;           ///< ends the render and cloud threads
  std::thread predict_thread_;  ///< rendered/depth_predicted (predictLoop)
  std::thread view_thread_;     ///< rendered/color and rendered/depth (viewLoop)
  std::thread cloud_thread_;    ///< builds and publishes map_cloud and gaussian_cloud (cloudLoop)
  ros::Publisher cloud_pub_, gaussian_cloud_pub_, color_pub_, depth_pub_, predicted_pub_;
  ros::Subscriber keyframe_sub_, corrections_sub_, status_sub_;
  ros::ServiceServer save_srv_, reset_srv_, load_srv_;
  std::filesystem::file_time_type start_time_;  ///< session halves older than this are not this run's
  /// ~save_session and ~load_session: their own queue and thread (the tracking nodelet calls them).
  std::unique_ptr<rc::OwnThreadServices> session_services_;
  std::unique_ptr<rc::NodeletDiagnostics> diagnostics_;  ///< last: destroyed first (its task reads the stage)
  ros::WallTime last_diagnosis_{0.0};                    ///< diagnostics timer only
  std::int64_t iterations_at_last_diagnosis_ = 0;
  std::size_t merged_at_last_diagnosis_ = 0;
};

}  // namespace dypho::mapping_ros

PLUGINLIB_EXPORT_CLASS(dypho::mapping_ros::GaussianMappingNodelet, nodelet::Nodelet)
