/// TrackingNodelet: synchronised rgb + depth + camera_info and the dynamic mask in; pose, path, tf
/// (map -> odom -> camera, REP-105), tracking status (with the pose and its jump flags, which the
/// mask and mapping nodelets feed their motion models with, and the live figures), keyframes,
/// keyframe correction batches, timing and /diagnostics out. All the tracking and its policy are
/// in dypho::tracking::TrackingStage (the same stage the in-process pipeline runs).
///
/// Sessions (issue 36, session_folder.h): ~save_session writes tracker.bin and asks the mapping
/// nodelet (~mapping_node) for map.ply, whose completion writes the manifest; ~load_session and
/// ~session read a saved session, have mapping load its map, and restore the tracker at the next
/// frame (its camera checked there), which then searches the loaded map. On shutdown with
/// output_dir each nodelet writes its half into output_dir/session and the second writes the
/// manifest. Session services run on a queue and thread of their own, so that the call to the
/// mapping nodelet never waits for a manager thread this nodelet holds.
///
/// Threads: the live tracking itself, pairing each frame with its mask, preparing features and
/// tracking on threads of their own, dropping and counting, is dypho::tracking::LiveTracker (the
/// same code dypho_run_dataset --realtime runs); the callbacks only hand it message pointers, and
/// its sink publishes here.

#include <filesystem>
#include <memory>
#include <mutex>
#include <utility>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/KeyframeCorrections.h>
#include <dypho_slam/LoadMap.h>
#include <dypho_slam/Reset.h>
#include <dypho_slam/SaveMap.h>
#include <dypho_slam/StageTiming.h>
#include <dypho_slam/TrackingStatus.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <tf2_ros/transform_broadcaster.h>

#include "dypho/common/output_path.h"
#include "dypho/common/rolling_stats.h"
#include "dypho/pipeline/session_folder.h"
#include "dypho/tracking/live_tracker.h"
#include "dypho/tracking/tracking_options_fields.h"
#include "dypho/tracking/tracking_stage.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/frame_camera.h"
#include "dypho_ros/nodelet_runtime.h"
#include "dypho_ros/param_reader.h"
#include "dypho_ros/path_publisher.h"
#include "dypho_ros/sync_watchdog.h"
#include "dypho_ros/throttled_log.h"
#include "tracking_conversions.h"

namespace dypho::tracking_ros {

namespace rc = dypho::ros_conversions;
using sensor_msgs::CameraInfo;
using sensor_msgs::Image;

/// Frames and outputs of the nodelet (not part of the core options).
struct TrackingRosParams {
  std::string map_frame = "map";    ///< REP-105 world frame
  std::string odom_frame = "odom";  ///< REP-105 odometry frame (map -> odom is identity until loop closure)
  std::string camera_frame;         ///< tracked camera optical frame; empty = the rgb header's frame_id
  bool publish_tf = true;           ///< broadcast map -> odom -> camera_frame
  bool use_mask = true;             ///< subscribe to the dynamic mask and track only static pixels
  std::string camera_file;          ///< camera file whose intrinsics replace camera_info's; empty = camera_info
  /// Synchroniser and subscriber queues [messages]: 1 s at 30 Hz, so that frames that arrive in
  /// a burst after the manager's threads were held up are not dropped before the pairer.
  int queue_size = 30;
  double watchdog_s = 5.0;  ///< warn when no synchronised input for this long [s]
  /// where trajectory.txt is written on shutdown; ~save_trajectory writes only inside it
  /// (empty: $ROS_HOME/dypho, default ~/.ros/dypho, resolved at start-up)
  std::string output_dir;
  int max_path_length = 20000;                ///< path poses kept, newest (11 min at 30 Hz) [poses], >= 1
  double path_period_s = 0.5;                 ///< the path is published at most this often, when it changed [s], > 0
  tracking::MaskPairingOptions mask_pairing;  ///< ~mask_max_wait_s, ~mask_max_pending_frames, ~mask_max_carry_age_s
  /// A saved session to go on from (a session folder, or a run's output folder holding
  /// session/): restored at the first frame, which then searches its map. Empty: a new map.
  std::string session;
  /// The mapping nodelet's name (its services are <namespace>/<mapping_node>/save_session and
  /// load_session), for saving and loading the map half of a session.
  std::string mapping_node = "mapping";
};

class TrackingNodelet : public nodelet::Nodelet {
  using Policy3 = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;

  /// One synchronised input set, held as message pointers (no copy) until tracked.
  struct FrameMsgs {
    sensor_msgs::ImageConstPtr rgb, depth;
    sensor_msgs::CameraInfoConstPtr info;
  };
  using Live = tracking::LiveTracker<FrameMsgs, sensor_msgs::ImageConstPtr>;

 public:
  /// A bad parameter leaves this nodelet idle with a FATAL reason (rc::startOrStayIdle).
  void onInit() override {
    rc::startOrStayIdle(getName(), [this] { start(); });
  }

  void start() {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    // 1. Parameters.
    const tracking::TrackingOptions options = readParameters(pnh);

    // 2. Core, and the session to go on from (a session that cannot be read leaves the nodelet
    // idle with the reason: going on in an empty map would silently not be what was asked).
    stage_ = std::make_unique<tracking::TrackingStage>(options);
    start_time_ = std::filesystem::file_time_type::clock::now();
    if (!params_.session.empty()) {
      NODELET_INFO_STREAM("~session: " << readSession(params_.session));
    } else if (options.localization_only) {
      NODELET_WARN_STREAM("localization_only without ~session: nothing is tracked until ~load_session loads one");
    }

    // 3. Outputs.
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>("pose", 10);
    pose_covariance_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose_with_covariance", 10);
    path_ = std::make_unique<rc::ThrottledPathPublisher>(nh, "path", params_.map_frame, params_.max_path_length,
                                                         params_.path_period_s);
    status_pub_ = nh.advertise<dypho_slam::TrackingStatus>("tracking_status", 10);
    keyframe_pub_ = nh.advertise<dypho_slam::Keyframe>("keyframe", 10);
    corrections_pub_ = nh.advertise<dypho_slam::KeyframeCorrections>("keyframe_corrections", 100);
    timing_pub_ = nh.advertise<dypho_slam::StageTiming>("tracking/timing", 10);
    moving_points_pub_ = nh.advertise<sensor_msgs::PointCloud2>("moving_points", 5);
    reset_srv_ = pnh.advertiseService("reset", &TrackingNodelet::onReset, this);
    save_srv_ = pnh.advertiseService("save_trajectory", &TrackingNodelet::onSave, this);
    session_services_ = std::make_unique<rc::OwnThreadServices>(pnh);
    session_services_->advertise("save_session", &TrackingNodelet::onSaveSession, this);
    session_services_->advertise("load_session", &TrackingNodelet::onLoadSession, this);
    session_services_->start();
    tf_broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();
    diagnostics_ = std::make_unique<rc::NodeletDiagnostics>(
        nh, pnh, getName(), "tracking", [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); });

    // 4. The live tracker's threads, then inputs.
    Live::Callbacks callbacks;
    callbacks.convert = [this](const Live::Ready& ready) { return toLiveFrame(ready); };
    callbacks.sink = [this](Live::Tracked& tracked) { onTracked(tracked); };
    callbacks.failure = [this](const tracking::LiveFailure& failure) {
      if (input_log_.pass(failure.message)) NODELET_ERROR_STREAM(failure.message);
    };
    live_ = std::make_unique<Live>(*stage_, params_.mask_pairing, params_.use_mask, std::move(callbacks));
    it_ = std::make_unique<image_transport::ImageTransport>(nh);
    const int q = params_.queue_size;
    rgb_sub_.subscribe(*it_, "rgb/image", q);
    depth_sub_.subscribe(*it_, "depth/image", q);
    info_sub_.subscribe(nh, "rgb/camera_info", q);
    std::vector<std::string> topics{nh.resolveName("rgb/image"), nh.resolveName("depth/image"),
                                    nh.resolveName("rgb/camera_info")};
    sync3_ = std::make_unique<message_filters::Synchronizer<Policy3>>(Policy3(q), rgb_sub_, depth_sub_, info_sub_);
    sync3_->registerCallback(&TrackingNodelet::frameCallback, this);
    if (params_.use_mask) mask_sub_ = it_->subscribe("mask", q, &TrackingNodelet::maskCallback, this);
    watchdog_ = std::make_unique<rc::SyncWatchdog>(nh, getName(), topics, params_.watchdog_s,
                                                   /*has_approx_sync=*/false);
  }

  /// The nodelet's parameters into params_, the core's returned (validated); throws on a bad one.
  tracking::TrackingOptions readParameters(ros::NodeHandle& pnh) {
    rc::RosParamReader reader(pnh);
    tracking::TrackingOptions options;
    tracking::visitOptions(options, reader);
    reader("map_frame", params_.map_frame, "");
    reader("odom_frame", params_.odom_frame, "");
    reader("camera_frame", params_.camera_frame, "");
    reader("publish_tf", params_.publish_tf, "");
    reader("use_mask", params_.use_mask, "");
    reader("camera_file", params_.camera_file, "");
    reader("queue_size", params_.queue_size, "");
    reader("watchdog_s", params_.watchdog_s, "");
    reader("output_dir", params_.output_dir, "");
    reader("max_path_length", params_.max_path_length, "");
    reader("path_period_s", params_.path_period_s, "");
    reader("mask_max_wait_s", params_.mask_pairing.max_wait_s, "");
    reader("mask_max_pending_frames", params_.mask_pairing.max_pending_frames, "");
    reader("mask_max_carry_age_s", params_.mask_pairing.max_carry_age_s, "");
    reader("session", params_.session, "");
    reader("mapping_node", params_.mapping_node, "");
    reader.checkNoUnknownKeys();
    if (params_.max_path_length < 1) throw std::invalid_argument("max_path_length must be >= 1");
    if (!(params_.path_period_s > 0)) throw std::invalid_argument("path_period_s must be > 0");
    params_.mask_pairing.validate();
    // Empty output_dir: $ROS_HOME/dypho (~/.ros/dypho); the shutdown save writes there.
    std::string output_warning;
    params_.output_dir = rc::prepareOutputDirectory(params_.output_dir, output_warning);
    if (!output_warning.empty()) NODELET_WARN_STREAM(output_warning << ": set ~output_dir to keep the trajectory");
    options.validate();
    camera_ = std::make_unique<rc::FrameCamera>(params_.camera_file);  // throws naming a bad file
    // -1 = the camera file's readout, as in the dataset runner; without a file, a global shutter.
    if (options.rolling_shutter_readout_ms < 0.0 && camera_->rollingShutterReadoutMs()) {
      options.rolling_shutter_readout_ms = *camera_->rollingShutterReadoutMs();
    }
    NODELET_INFO_STREAM("tracking parameters:" << reader.summary() << "\noutputs go to " << params_.output_dir << "\n"
                                               << camera_->describe());
    return options;
  }

  /// Shutdown order (nodelet_runtime.h): the path, diagnostics, the live tracker's threads (the
  /// frames already prepared are still published), then the tracker's end of run (final global
  /// BA) and the trajectory is written.
  ~TrackingNodelet() override {
    if (session_services_) session_services_->stop();
    if (path_) path_->stopPublishing();
    if (diagnostics_) diagnostics_->stop();
    if (live_) live_->stop();
    if (!stage_) return;
    rc::saveOnShutdown(getName(), params_.output_dir, stage_->numFrames() == 0, "no frame tracked", [this] {
      finishRun();
      saveTrajectory(params_.output_dir);
    });
    // A resumed run that never found the camera still writes its (restored) half, so that the
    // mapping nodelet's half does not leave the folder without a manifest.
    rc::saveOnShutdown(getName(), params_.output_dir,
                       stage_->options().localization_only || stage_->odometry().map().keyframes().empty(),
                       "no session (localization_only, or no keyframe)", [this] { saveSessionHalfOnShutdown(); });
  }

 private:
  // --- callbacks: hand the pointers to the live tracker ----------------------------------------
  void frameCallback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                     const sensor_msgs::CameraInfoConstPtr& info) {
    watchdog_->tick();
    live_->addFrame(rc::toTimestamp(rgb->header.stamp), FrameMsgs{rgb, depth, info});
  }

  void maskCallback(const sensor_msgs::ImageConstPtr& mask) {
    live_->addMask(rc::toTimestamp(mask->header.stamp), mask);
  }

  /// The live tracker's conversion (its preparing thread): throws rc::ConversionError on bad input.
  tracking::LiveFrame toLiveFrame(const Live::Ready& ready) const {
    tracking::LiveFrame out;
    std::string camera_warning;
    out.frame =
        rc::toRgbdFrame(*ready.frame.rgb, *ready.frame.depth, camera_->intrinsics(*ready.frame.info, &camera_warning));
    if (!camera_warning.empty()) NODELET_WARN_STREAM(camera_warning);
    if (ready.mask) out.mask = rc::toMask(*ready.mask);
    return out;
  }

  // --- the live tracker's sink (its tracking thread): publish ---------------------------------
  void onTracked(const Live::Tracked& tracked) {
    const tracking::TrackingOutput& out = tracked.output;
    if (out.dropped) {  // repeated or late stamp: nothing to publish for it
      if (input_log_.pass(out.result.message)) NODELET_WARN_STREAM(out.result.message);
      return;
    }
    const tracking::MaskSource source = tracked.ready.source;
    if (source != tracking::MaskSource::kMatched && params_.use_mask) {
      const std::string message = std::string("a frame's mask did not come within mask_max_wait_s (") +
                                  std::to_string(params_.mask_pairing.max_wait_s) + " s): tracked with " +
                                  (source == tracking::MaskSource::kCarried ? "the nearest mask in time" : "no mask") +
                                  " (counted in tracking_status; the mask nodelet is slower than the camera)";
      if (mask_log_.pass(message)) NODELET_WARN_STREAM(message);
    }
    publish(out, tracked.ready.frame.rgb->header, source, tracked.live);
  }

  void publish(const tracking::TrackingOutput& out, const std_msgs::Header& header, tracking::MaskSource source,
               const tracking::LiveFrameFigures& live) {
    const tracking::TrackingResult& result = out.result;
    const std::string camera_frame = params_.camera_frame.empty() ? header.frame_id : params_.camera_frame;
    if (out.restarted) NODELET_WARN_STREAM("time jumped backwards (bag restarted?): tracking and path restart");
    if (!out.session_event.empty()) NODELET_WARN_STREAM("session: " << out.session_event);
    auto status = boost::make_shared<dypho_slam::TrackingStatus>(toStatusMsg(out, header, camera_frame, source, live));
    fillLiveFigures(*status);
    // The moving points go out before the status: the mask's next frame waits for the status
    // (previous_pose_wait_s) and then takes the newest points it has.
    if (!result.moving_points_camera_m.empty()) {
      std_msgs::Header points_header = header;
      points_header.frame_id = camera_frame;
      moving_points_pub_.publish(rc::toPointCloudMsg(result.moving_points_camera_m, points_header));
    }
    status_pub_.publish(status);
    if (result.state != tracking::TrackingState::kOk) {
      const std::string message = std::string("tracking ") + tracking::toString(result.state) + ": " + result.message;
      if (state_log_.pass(message)) NODELET_WARN_STREAM(message);
    } else if (result.relocalized || result.loop_closed) {
      NODELET_INFO_STREAM("tracking: " << result.message);
    }
    timing_pub_.publish(toTimingMsg(result, header));
    publishCorrections(out.corrections(), header.stamp);
    // Never publish a pose we do not trust, nor one not anchored to the map (re-initialised).
    if (!out.pose.trusted || !out.pose.anchored) return;
    auto pose = boost::make_shared<geometry_msgs::PoseStamped>();
    pose->header.stamp = header.stamp;
    pose->header.frame_id = params_.map_frame;
    pose->pose = rc::toPoseMsg(result.T_world_camera);
    pose_pub_.publish(pose);
    if (result.pose_covariance.valid) pose_covariance_pub_.publish(toPoseWithCovarianceMsg(result, pose->header));
    updatePath(*pose, result.is_keyframe || result.loop_closed || out.restarted);
    if (params_.publish_tf) {
      const auto tfs = toTfMsgs(result.T_world_camera, out.T_map_odom, header.stamp, params_.map_frame,
                                params_.odom_frame, camera_frame);
      if (!tfs.empty()) tf_broadcaster_->sendTransform(tfs);
    }
    if (result.keyframe) keyframe_pub_.publish(rc::toKeyframeMsg(*result.keyframe, camera_frame));
  }

  /// The live tracker's counters, the latency of this frame and of the last frames, into the
  /// status and the diagnostics.
  void fillLiveFigures(dypho_slam::TrackingStatus& status) {
    const double latency_ms = (ros::Time::now() - status.header.stamp).toSec() * 1e3;
    fillLiveCounters(status, live_->counters(), live_->statistics());
    std::lock_guard<std::mutex> lock(figures_mutex_);
    latency_ms_.add(latency_ms);
    status.latency_ms = static_cast<float>(latency_ms);
    status.latency_p50_ms = static_cast<float>(latency_ms_.percentile(0.5));
    status.latency_p95_ms = static_cast<float>(latency_ms_.percentile(0.95));
    last_status_ = status;
  }

  /// /diagnostics: the same figures, with a level a user can act on.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
    std::lock_guard<std::mutex> lock(figures_mutex_);
    const dypho_slam::TrackingStatus& s = last_status_;
    const std::uint64_t dropped_now = s.frames_dropped - dropped_at_last_diagnosis_;
    dropped_at_last_diagnosis_ = s.frames_dropped;
    if (s.frames_processed == 0) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no frame tracked yet (check the input topics)");
    } else if (s.state == dypho_slam::TrackingStatus::LOST) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "tracking lost: " + s.message);
    } else if (dropped_now > 0) {
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                    "%lu frames dropped since the last report: tracking is slower than the camera",
                    static_cast<unsigned long>(dropped_now));
    } else {
      stat.summary(diagnostic_msgs::DiagnosticStatus::OK,
                   s.state == dypho_slam::TrackingStatus::OK ? "tracking" : "initialising");
    }
    stat.add("input rate [Hz]", s.input_rate_hz);
    stat.add("frames in", s.frames_in);
    stat.add("frames processed", s.frames_processed);
    stat.add("frames dropped", s.frames_dropped);
    stat.add("frames with a carried mask", s.frames_mask_carried);
    stat.add("frames tracked catching up", s.frames_caught_up);
    stat.add("frames without a mask", s.frames_without_mask);
    stat.add("mask of the last frame", tracking::toString(static_cast<tracking::MaskSource>(s.mask_source)));
    stat.add("latency p50 [ms]", s.latency_p50_ms);
    stat.add("latency p95 [ms]", s.latency_p95_ms);
    stat.add("tracking p50 [ms]", s.tracking_p50_ms);
    stat.add("tracking p95 [ms]", s.tracking_p95_ms);
    stat.add("features", s.num_features);
    stat.add("inliers", s.num_inliers);
    stat.add("masked fraction", s.masked_fraction);
  }

  /// The path of trusted poses (the newest max_path_length); redrawn from the final poses when
  /// keyframes moved (local BA, loop closure), else extended by `pose`.
  void updatePath(const geometry_msgs::PoseStamped& pose, bool redraw) {
    if (!redraw) {
      path_->append(pose);
      return;
    }
    const tracking::PoseList redrawn = stage_->trackedPath(static_cast<std::size_t>(params_.max_path_length));
    std::vector<geometry_msgs::PoseStamped> poses;
    poses.reserve(redrawn.size());
    for (const auto& [stamp_ns, T_world_camera] : redrawn) {
      geometry_msgs::PoseStamped p = pose;
      p.header.stamp = rc::toRosTime(stamp_ns);
      p.pose = rc::toPoseMsg(T_world_camera);
      poses.push_back(p);
    }
    path_->replace(std::move(poses), pose.header.stamp);
  }

  /// Keyframe poses moved by local BA or loop closure, one batch, for mapping to re-anchor.
  void publishCorrections(const KeyframePoseCorrections& corrections, const ros::Time& stamp) {
    if (corrections.empty()) return;
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = params_.map_frame;
    corrections_pub_.publish(rc::toCorrectionsMsg(corrections, header));
  }

  bool onReset(dypho_slam::Reset::Request&, dypho_slam::Reset::Response& res) {
    stage_->reset();
    live_->clearWaiting();
    path_->clear();
    res.success = true;
    res.message = "tracking reset";
    return true;
  }

  bool onSave(dypho_slam::SaveMap::Request& req, dypho_slam::SaveMap::Response& res) {
    try {
      // Only under the output directory: a ROS 1 service can be called by anyone on the network.
      const std::string dir = resolveOutputDirectory(rc::outputBaseDirectory(params_.output_dir), req.directory);
      std::filesystem::create_directories(dir);
      res.files.push_back(saveTrajectory(dir));
      res.success = true;
      res.message = "trajectory written";
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    return true;
  }

  // --- sessions (session_folder.h) -------------------------------------------------------------

  /// Reads the session at `path` (a session folder or a run's output folder) and restores it at
  /// the next frame; returns what was read. Throws std::runtime_error naming the file.
  std::string readSession(const std::string& path) {
    const std::string dir = pipeline::resolveSessionDir(path);
    const pipeline::SessionManifest m =
        pipeline::readSessionManifest(pipeline::sessionFile(dir, pipeline::kSessionManifestFile));
    // The camera is the run's once its first frame comes: checked there (restoreSessionAtNextFrame).
    tracking::TrackerSession session = pipeline::readSessionTracker(dir, m, m.camera);
    stage_->restoreSessionAtNextFrame(std::move(session));
    return "session " + dir + " (" + std::to_string(m.num_keyframes) + " keyframes, " +
           std::to_string(m.num_map_points) + " map points, saved " + m.created_utc +
           "): restored at the next frame, which searches the loaded map";
  }

  /// Calls the mapping nodelet's `service`; empty on success, else why not.
  template <class Service>
  std::string callMapping(const std::string& service, Service& call) {
    const std::string name = getNodeHandle().resolveName(params_.mapping_node + "/" + service);
    if (!ros::service::waitForService(name, ros::Duration(5.0))) {
      return name + " did not answer within 5 s (is the mapping nodelet running, named by ~mapping_node?)";
    }
    if (!ros::service::call(name, call)) return "calling " + name + " failed";
    if (!call.response.success) return name + ": " + call.response.message;
    return "";
  }

  /// ~save_session: tracker.bin into <output_dir>/<directory>/session, then the mapping
  /// nodelet's map.ply into the same folder, whose completion writes the manifest.
  bool onSaveSession(dypho_slam::SaveMap::Request& req, dypho_slam::SaveMap::Response& res) {
    try {
      const std::string dir =
          pipeline::sessionFolderIn(resolveOutputDirectory(rc::outputBaseDirectory(params_.output_dir), req.directory));
      const tracking::TrackerSession session = stage_->session();  // throws before the first keyframe
      pipeline::beginSessionSave(dir);
      const std::string tracker_path = pipeline::sessionFile(dir, pipeline::kSessionTrackerFile);
      tracking::saveTrackerSession(tracker_path, session);
      res.files.push_back(tracker_path);
      dypho_slam::SaveMap map_half;
      map_half.request.directory = req.directory;
      const std::string problem = callMapping("save_session", map_half);
      if (!problem.empty()) throw std::runtime_error("tracker.bin written, the map half not: " + problem);
      res.files.insert(res.files.end(), map_half.response.files.begin(), map_half.response.files.end());
      const std::string manifest_path = pipeline::sessionFile(dir, pipeline::kSessionManifestFile);
      const pipeline::SessionManifest m = pipeline::readSessionManifest(manifest_path);
      res.files.push_back(manifest_path);
      res.success = true;
      res.message = "session saved to " + dir + ": " + std::to_string(m.num_keyframes) + " keyframes, " +
                    std::to_string(m.num_map_points) + " map points, " + std::to_string(m.num_gaussians) +
                    " Gaussians, " + std::to_string(pipeline::sessionBytes(dir)) + " bytes";
      NODELET_INFO_STREAM(res.message);
    } catch (const std::exception& e) {
      res.success = false;
      res.message = std::string("session not saved: ") + e.what();
      NODELET_WARN_STREAM(res.message);
    }
    return true;
  }

  /// ~load_session: the session at `path` read and checked, its map loaded by the mapping
  /// nodelet, then the tracker restored at the next frame. On any error nothing changes.
  bool onLoadSession(dypho_slam::LoadMap::Request& req, dypho_slam::LoadMap::Response& res) {
    try {
      const std::string dir = pipeline::resolveSessionDir(req.path);
      const pipeline::SessionManifest m =
          pipeline::readSessionManifest(pipeline::sessionFile(dir, pipeline::kSessionManifestFile));
      tracking::TrackerSession session = pipeline::readSessionTracker(dir, m, m.camera);
      dypho_slam::LoadMap map_half;
      map_half.request.path = dir;
      const std::string problem = callMapping("load_session", map_half);
      if (!problem.empty()) throw std::runtime_error("the map half did not load: " + problem);
      stage_->restoreSessionAtNextFrame(std::move(session));
      live_->clearWaiting();
      path_->clear();
      res.success = true;
      res.message = "session " + dir + " loaded (" + std::to_string(m.num_keyframes) + " keyframes, " +
                    std::to_string(m.num_gaussians) + " Gaussians): the next frame searches its map";
      NODELET_INFO_STREAM(res.message);
    } catch (const std::exception& e) {
      res.success = false;
      res.message = std::string("session not loaded, tracking unchanged: ") + e.what();
      NODELET_WARN_STREAM(res.message);
    }
    return true;
  }

  /// At shutdown, after the trajectory: tracker.bin into output_dir/session, and the manifest
  /// when the mapping nodelet's half is there already (else its shutdown writes it).
  void saveSessionHalfOnShutdown() {
    const std::string dir = pipeline::sessionFolderIn(params_.output_dir);
    try {
      const tracking::TrackerSession session = stage_->session();
      pipeline::beginSessionSave(dir);
      tracking::saveTrackerSession(pipeline::sessionFile(dir, pipeline::kSessionTrackerFile), session);
      std::string why;
      if (pipeline::completeSession(dir, start_time_, "ROS graph (" + getName() + ")", &why)) {
        NODELET_INFO_STREAM("session saved to " << dir);
      } else {
        NODELET_INFO_STREAM("tracker half of the session written to "
                            << dir << "; the mapping nodelet's shutdown completes it (" << why << ")");
      }
    } catch (const std::logic_error&) {
      NODELET_INFO_STREAM("no keyframe: no session to save");
    }
  }

  /// At shutdown, before the trajectory is saved: the final global BA
  /// (TrackingOptions::global_ba_at_end), which trajectory.txt then follows. Its keyframe
  /// corrections are not published: the graph is going down.
  void finishRun() {
    const tracking::RunEnd end = stage_->finishRun();
    NODELET_INFO_STREAM("final global BA: "
                        << tracking::describe(end.global_ba) << ", " << end.corrected_keyframes.size()
                        << " keyframes corrected; " << end.frame_refinement.frames_refined
                        << " frames refined against the final map, " << end.frame_refinement.frames_kept
                        << " kept as tracked (" << end.frame_refinement.frames_out_of_time << " for lack of time; "
                        << end.frame_refinement.ms << " ms)");
  }

  std::string saveTrajectory(const std::string& dir) {
    // trajectory.txt: tracked frames following the final poses of their keyframes (after local BA
    // and loop closure); trajectory_online.txt: the poses as published; keyframes.txt.
    const std::vector<std::string> paths = stage_->saveTrajectories(dir);
    NODELET_INFO_STREAM("wrote " << stage_->numFrames() << " poses to " << paths.front()
                                 << " (and trajectory_online.txt, keyframes.txt)");
    return paths.front();
  }

  TrackingRosParams params_;
  std::unique_ptr<tracking::TrackingStage> stage_;     ///< thread-safe: the live tracker's thread, services, shutdown
  rc::ThrottledLog input_log_, state_log_, mask_log_;  ///< each kind of problem is named at once, then every 5 s
  std::mutex figures_mutex_;  ///< guards the latencies and the last status (tracking thread, diagnostics)
  RollingSamples latency_ms_;
  dypho_slam::TrackingStatus last_status_;
  std::uint64_t dropped_at_last_diagnosis_ = 0;
  /// Pairs, prepares, tracks and calls onTracked(); stopped in the destructor before anything its
  /// sink uses goes, destroyed after the subscriptions that feed it.
  std::unique_ptr<Live> live_;

  std::unique_ptr<rc::ThrottledPathPublisher> path_;

  ros::Publisher pose_pub_, status_pub_, keyframe_pub_, corrections_pub_, timing_pub_;
  /// The pose with its covariance relative to the map's points (PoseCovariance), when it has one.
  ros::Publisher pose_covariance_pub_;
  ros::Publisher moving_points_pub_;  ///< features seen moving (sensor_msgs/PointCloud2, camera optical frame)
  ros::ServiceServer reset_srv_, save_srv_;
  std::filesystem::file_time_type start_time_;  ///< session halves older than this are not this run's
  /// ~save_session and ~load_session: their own queue and thread (they call the mapping nodelet).
  std::unique_ptr<rc::OwnThreadServices> session_services_;
  std::unique_ptr<rc::NodeletDiagnostics> diagnostics_;  ///< after what its task uses: destroyed first
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_broadcaster_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter rgb_sub_, depth_sub_;
  image_transport::Subscriber mask_sub_;
  message_filters::Subscriber<CameraInfo> info_sub_;
  std::unique_ptr<rc::FrameCamera> camera_;  ///< camera_info's intrinsics or camera_file's (preparing thread)
  std::unique_ptr<message_filters::Synchronizer<Policy3>> sync3_;
  std::unique_ptr<rc::SyncWatchdog> watchdog_;
};

}  // namespace dypho::tracking_ros

PLUGINLIB_EXPORT_CLASS(dypho::tracking_ros::TrackingNodelet, nodelet::Nodelet)
