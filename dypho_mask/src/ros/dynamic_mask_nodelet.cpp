/// DynamicMaskNodelet: synchronised rgb + depth + camera_info in, dynamic mask (mono8, 255 =
/// dynamic) out. All the work and its policy are in dypho::mask::MaskStage (the same stage the
/// in-process pipeline runs). Optional inputs, never waited for: `tracking_status` (the tracked
/// pose with its jump flags, for the ego-motion prior) and `rendered/depth_predicted` (R_d, the
/// map's depth at the predicted pose of the frame with the same stamp).
///
/// Threads: the synchronised callback only stores the message pointers; one worker thread masks
/// the oldest waiting frame (BoundedHandOver). When more than ~max_waiting_frames wait (the mask is slower than the
/// camera), the oldest is skipped and counted: tracking then carries the nearest mask to it. The
/// network (yolo_async) runs on its own lower-priority thread beside it. `~cores` sets OpenCV's
/// pool for the whole process (thread_budget.h).

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dypho_slam/MaskStatus.h>
#include <dypho_slam/StageTiming.h>
#include <dypho_slam/TrackingStatus.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <opencv2/core.hpp>
#include <sensor_msgs/image_encodings.h>

#include "dypho/common/bounded_hand_over.h"
#include "dypho/common/rolling_stats.h"
#include "dypho/common/thread_budget.h"

#include "dypho/mask/mask_options_fields.h"
#include "dypho/mask/mask_stage.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/frame_camera.h"
#include "dypho_ros/nodelet_runtime.h"
#include "dypho_ros/param_reader.h"
#include "dypho_ros/sync_watchdog.h"
#include "dypho_ros/throttled_log.h"

namespace dypho::mask_ros {

namespace rc = dypho::ros_conversions;
using sensor_msgs::CameraInfo;
using sensor_msgs::Image;

class DynamicMaskNodelet : public nodelet::Nodelet {
  using ApproxPolicy = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;
  using ExactPolicy = message_filters::sync_policies::ExactTime<Image, Image, CameraInfo>;

 public:
  /// A bad parameter leaves this nodelet idle with a FATAL reason (rc::startOrStayIdle); a
  /// missing model is only a warning, below.
  void onInit() override {
    rc::startOrStayIdle(getName(), [this] { start(); });
  }

  /// onInit()'s work, in order: parameters, core, outputs, inputs.
  void start() {
    const StartParameters params = loadParameters();
    startStage(params.options, params.stage_options);
    advertise();
    subscribe(params);
  }

  /// Shutdown order (nodelet_runtime.h): diagnostics, then the worker; the mask writes no file.
  ~DynamicMaskNodelet() override {
    if (diagnostics_) diagnostics_->stop();
    stopping_ = true;  // the frames still waiting are not masked
    if (waiting_) waiting_->close();
    if (worker_.joinable()) worker_.join();
  }

 private:
  /// What start() reads from the private parameters (besides max_waiting_frames_).
  struct StartParameters {
    mask::DynamicMaskOptions options;
    mask::MaskStageOptions stage_options;
    int queue_size = 30;  // 1 s at 30 Hz: a burst after a held-up moment is not dropped here
    bool approx_sync = true;
    double watchdog_s = 5.0;
    std::string camera_file;  // empty = each frame's camera_info (frame_camera.h)
  };

  /// 1. Parameters: reads, checks and prints them, and sets OpenCV's pool (thread budget).
  StartParameters loadParameters() {
    rc::RosParamReader reader(getPrivateNodeHandle());
    StartParameters p;
    mask::visitOptions(p.options, reader);
    int cores = 0;
    reader("queue_size", p.queue_size, "synchroniser queue length [messages]");
    reader("approx_sync", p.approx_sync, "approximate-time sync of rgb/depth/camera_info");
    reader("watchdog_s", p.watchdog_s, "warn when no input arrived for this long [s]; 0 = off");
    reader("camera_file", p.camera_file, "camera file whose intrinsics replace camera_info's; empty = camera_info");
    reader("rendered_depth_tolerance_s", p.stage_options.rendered_depth_tolerance_s,
           "R_d is used by the frame whose stamp is within this of its stamp [s]");
    reader("previous_pose_wait_s", p.stage_options.previous_pose_wait_s,
           "after its flow, a frame's mask waits at most this long for the previous frame's tracked pose, unless "
           "frames wait behind it [s]; 0 = never");
    reader("max_waiting_frames", max_waiting_frames_,
           "frames waiting for the mask worker; beyond it the oldest is skipped and counted, >= 1");
    reader("cores", cores, "cores of the thread budget (0 = every core): OpenCV's pool gets half");
    reader.checkNoUnknownKeys();
    if (max_waiting_frames_ < 1) throw std::invalid_argument("max_waiting_frames must be >= 1");
    const ThreadBudget budget = planThreadBudget(cores);
    cv::setNumThreads(budget.opencv_threads);  // process-wide: the manager's nodelets share it
    NODELET_INFO_STREAM("thread budget: " << budget.cores << " cores, OpenCV pool " << budget.opencv_threads
                                          << " threads, network nice +" << p.options.yolo.async_nice
                                          << (p.options.yolo.async ? " (asynchronous)" : " (in the mask thread)"));
    p.options.validate();
    camera_ = std::make_unique<rc::FrameCamera>(p.camera_file);  // throws naming a bad file
    NODELET_INFO_STREAM("dynamic mask parameters:" << reader.summary() << "\n" << camera_->describe());
    return p;
  }

  /// 2. Core: the mask stage, with the network's status logged once.
  void startStage(const mask::DynamicMaskOptions& options, const mask::MaskStageOptions& stage_options) {
    stage_ = std::make_unique<mask::MaskStage>(options, stage_options);
    const std::string& status = stage_->masker().segmentStatus();
    if (!options.yolo.model_path.empty() && !stage_->masker().segmentReady()) {
      NODELET_WARN_STREAM(status);  // once; flow + background keep working
    } else {
      NODELET_INFO_STREAM(status);
    }
  }

  /// 3. Outputs: the mask topics, status, timing and diagnostics, and the mask worker thread.
  void advertise() {
    ros::NodeHandle& nh = getNodeHandle();
    it_ = std::make_unique<image_transport::ImageTransport>(nh);
    mask_pub_ = it_->advertise("mask", 5);
    raw_pub_ = it_->advertise("mask/raw_flow", 2);
    raw_segment_pub_ = it_->advertise("mask/raw_segment", 2);
    consistency_pub_ = it_->advertise("mask/raw_consistency", 2);
    timing_pub_ = nh.advertise<dypho_slam::StageTiming>("mask/timing", 10);
    status_pub_ = nh.advertise<dypho_slam::MaskStatus>("mask/status", 10);
    diagnostics_ = std::make_unique<rc::NodeletDiagnostics>(
        nh, getPrivateNodeHandle(), getName(), "mask",
        [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); });
    waiting_ = std::make_unique<BoundedHandOver<FrameMsgs>>(static_cast<std::size_t>(max_waiting_frames_));
    worker_ = std::thread([this] { workerLoop(); });
  }

  /// 4. Inputs: the synchronised rgb + depth + camera_info, the optional inputs, the watchdog.
  void subscribe(const StartParameters& p) {
    ros::NodeHandle& nh = getNodeHandle();
    rgb_sub_.subscribe(*it_, "rgb/image", p.queue_size);
    depth_sub_.subscribe(*it_, "depth/image", p.queue_size);
    info_sub_.subscribe(nh, "rgb/camera_info", p.queue_size);
    tracking_sub_ = nh.subscribe("tracking_status", 20, &DynamicMaskNodelet::trackingCallback, this);
    if (stage_->masker().options().moving_point_seeds) {
      moving_points_sub_ = nh.subscribe("moving_points", 5, &DynamicMaskNodelet::movingPointsCallback, this);
    }
    if (stage_->wantsRenderedDepth()) {  // else mapping renders no R_d for us (no subscriber)
      rendered_sub_ = it_->subscribe("rendered/depth_predicted", 2, &DynamicMaskNodelet::renderedCallback, this);
    }
    if (p.approx_sync) {
      approx_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy>>(ApproxPolicy(p.queue_size), rgb_sub_,
                                                                              depth_sub_, info_sub_);
      approx_->registerCallback(&DynamicMaskNodelet::callback, this);
    } else {
      exact_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(ExactPolicy(p.queue_size), rgb_sub_,
                                                                            depth_sub_, info_sub_);
      exact_->registerCallback(&DynamicMaskNodelet::callback, this);
    }
    watchdog_ = std::make_unique<rc::SyncWatchdog>(
        nh, getName(),
        std::vector<std::string>{nh.resolveName("rgb/image"), nh.resolveName("depth/image"),
                                 nh.resolveName("rgb/camera_info")},
        p.watchdog_s, /*has_approx_sync=*/true);
  }

  /// One synchronised input set, held as message pointers (no copy) until masked.
  struct FrameMsgs {
    sensor_msgs::ImageConstPtr rgb, depth;
    sensor_msgs::CameraInfoConstPtr info;
    double arrival_s = 0.0;
  };

  void callback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                const sensor_msgs::CameraInfoConstPtr& info) {
    watchdog_->tick();
    const double now = steadyClockSeconds();
    const bool dropped = waiting_->push(FrameMsgs{rgb, depth, info, now}).has_value();
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++frames_in_;
    if (dropped) ++frames_dropped_busy_;
    input_rate_.add(now);
  }

  void workerLoop() {
    nameCurrentThread("dypho_mask");
    while (std::optional<FrameMsgs> msgs = waiting_->pop()) {
      if (stopping_) return;
      processFrame(*msgs);
    }
  }

  void processFrame(const FrameMsgs& msgs) {
    const sensor_msgs::ImageConstPtr& rgb = msgs.rgb;
    RgbdFrame frame;
    try {
      // Nominal intrinsics are pointed out by the tracking nodelet, where they cost the most: once.
      frame = rc::toRgbdFrame(*rgb, *msgs.depth, camera_->intrinsics(*msgs.info));
    } catch (const std::exception& e) {
      const std::string message = std::string("dropping frame: ") + e.what();
      if (input_log_.pass(message)) NODELET_ERROR_STREAM(message);
      return;
    }
    mask::MaskResult result;
    try {
      result = stage_->process(frame, waiting_->size());
    } catch (const std::exception& e) {  // never let a core error reach the manager's thread
      const std::string message = std::string("mask failed on this frame, dropped: ") + e.what();
      if (input_log_.pass(message)) NODELET_ERROR_STREAM(message);
      return;
    }
    if (result.dropped) {  // repeated or late stamp: no mask for it (tracking drops it too)
      if (input_log_.pass(result.message)) NODELET_WARN_STREAM(result.message);
      return;
    }
    if (result.degraded && !result.message.empty() && degraded_log_.pass(result.message)) {
      NODELET_WARN_STREAM("mask degraded: " << result.message);
    }
    // A frame nothing judged (the flow's first frame, no network) gets no mask: an all-static one
    // would say "no one here". Tracking goes on after its bounded wait and treats the frame as
    // unjudged (safe start); with unjudged_is_dynamic the all-dynamic mask is published.
    if (!result.unjudged || result.masked_fraction > 0.0) {
      mask_pub_.publish(rc::toImageMsg(result.mask, sensor_msgs::image_encodings::MONO8, rgb->header));
    }
    publishIfWanted(raw_pub_, result.raw_flow_mask, rgb->header);
    publishIfWanted(raw_segment_pub_, result.raw_segment_mask, rgb->header);
    publishIfWanted(consistency_pub_, result.consistency_mask, rgb->header);
    publishStatus(result, rgb->header, (steadyClockSeconds() - msgs.arrival_s) * 1e3);
  }

  void publishStatus(const mask::MaskResult& result, const std_msgs::Header& header, double latency_ms) {
    const mask::MaskStageStats stats = stage_->stats();
    auto status = boost::make_shared<dypho_slam::MaskStatus>();
    status->header = header;
    status->masked_fraction = static_cast<float>(result.masked_fraction);
    status->degraded = result.degraded;
    status->ego_motion_used = result.ego_motion_from_pose;
    status->rendered_depth_used = result.rendered_depth_used;
    status->frames = stats.frames;
    status->frames_with_ego_motion = stats.frames_with_ego_motion;
    status->frames_with_rendered_depth = stats.frames_with_rendered_depth;
    status->rendered_depth_offered = stats.rendered_depth_offered;
    status->rendered_depth_unmatched = stats.rendered_depth_unmatched;
    status->frames_dropped_out_of_order = stats.dropped_out_of_order;
    status->restarts = stats.restarts;
    status->frames_caught_up = stats.frames_caught_up;
    status->message = result.message;
    status->segment_source = result.segment_fresh               ? dypho_slam::MaskStatus::SEGMENT_FRESH
                             : !result.raw_segment_mask.empty() ? dypho_slam::MaskStatus::SEGMENT_CARRIED
                                                                : dypho_slam::MaskStatus::SEGMENT_NONE;
    status->segment_age_frames = result.segment_age_frames;
    status->network_runs = stats.network_runs;
    status->network_results_late = stats.network_results_late;
    {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      latency_ms_.add(latency_ms);
      status->frames_in = frames_in_;
      status->frames_dropped_busy = frames_dropped_busy_;
      status->latency_ms = static_cast<float>(latency_ms);
      status->latency_p50_ms = static_cast<float>(latency_ms_.percentile(0.5));
      status->latency_p95_ms = static_cast<float>(latency_ms_.percentile(0.95));
      status->input_rate_hz = static_cast<float>(input_rate_.rateHz(steadyClockSeconds()));
      last_status_ = *status;
    }
    status_pub_.publish(status);
    auto timing = boost::make_shared<dypho_slam::StageTiming>();
    timing->header = header;
    timing->node = "mask";
    timing->stages = {"flow", "segment", "background"};
    timing->ms = {static_cast<float>(result.flow_ms), static_cast<float>(result.segment_ms),
                  static_cast<float>(result.background_ms)};
    timing->total_ms = static_cast<float>(result.total_ms);
    timing_pub_.publish(timing);
  }

  /// /diagnostics: the mask's live figures, with a level a user can act on.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    const dypho_slam::MaskStatus& s = last_status_;
    const std::uint64_t dropped_now = s.frames_dropped_busy - dropped_at_last_diagnosis_;
    dropped_at_last_diagnosis_ = s.frames_dropped_busy;
    static const char* const kSegment[] = {"network, this frame", "network, carried", "flow and background only"};
    const char* segment = kSegment[std::min<int>(s.segment_source, 2)];
    if (s.frames == 0) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no frame masked yet (check the input topics)");
    } else if (dropped_now > 0) {
      stat.summaryf(
          diagnostic_msgs::DiagnosticStatus::WARN,
          "%lu frames skipped since the last report: the mask is slower than the camera (tracking carries masks)",
          static_cast<unsigned long>(dropped_now));
    } else if (s.network_runs >= 5 && 2 * s.network_results_late > s.network_runs) {
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                    "%lu of %lu network results came back too old to use: this machine is too slow for the network "
                    "at this frame rate (the mask runs on flow and background; the network runs less often)",
                    static_cast<unsigned long>(s.network_results_late), static_cast<unsigned long>(s.network_runs));
    } else if (s.degraded) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "degraded: " + s.message);
    } else {
      stat.summary(diagnostic_msgs::DiagnosticStatus::OK, segment);
    }
    stat.add("mask mode", segment);
    stat.add("network mask age [frames]", s.segment_age_frames);
    stat.add("network runs", s.network_runs);
    stat.add("network results too old", s.network_results_late);
    stat.add("input rate [Hz]", s.input_rate_hz);
    stat.add("frames in", s.frames_in);
    stat.add("frames masked", s.frames);
    stat.add("frames skipped (busy)", s.frames_dropped_busy);
    stat.add("latency p50 [ms]", s.latency_p50_ms);
    stat.add("latency p95 [ms]", s.latency_p95_ms);
    stat.add("masked fraction", s.masked_fraction);
    stat.add("R_d used on frames", s.frames_with_rendered_depth);
  }

  void publishIfWanted(image_transport::Publisher& pub, const cv::Mat& image, const std_msgs::Header& header) {
    if (pub.getNumSubscribers() > 0 && !image.empty()) {
      pub.publish(rc::toImageMsg(image, sensor_msgs::image_encodings::MONO8, header));
    }
  }

  void trackingCallback(const dypho_slam::TrackingStatusConstPtr& msg) { stage_->observePose(rc::toPoseUpdate(*msg)); }

  void movingPointsCallback(const sensor_msgs::PointCloud2ConstPtr& msg) {
    try {
      stage_->observeMovingPoints(rc::toMovingPoints(*msg));
    } catch (const std::exception& e) {
      const std::string message = std::string("moving points ignored: ") + e.what();
      if (input_log_.pass(message)) NODELET_WARN_STREAM(message);
    }
  }

  void renderedCallback(const sensor_msgs::ImageConstPtr& msg) {
    try {
      stage_->setPredictedDepth(rc::toTimestamp(msg->header.stamp), rc::toDepthMetres(*msg).clone());
    } catch (const std::exception& e) {
      NODELET_WARN_STREAM_THROTTLE(10.0, "ignoring rendered/depth_predicted: " << e.what());
    }
  }

  std::unique_ptr<rc::FrameCamera> camera_;  ///< camera_info's intrinsics or camera_file's (worker thread)
  std::unique_ptr<mask::MaskStage>
      stage_;  ///< the worker thread (and the optional-input callbacks, through its own lock)
  int max_waiting_frames_ = 2;

  std::unique_ptr<BoundedHandOver<FrameMsgs>> waiting_;  ///< frames for the worker; the oldest is skipped when full
  std::atomic<bool> stopping_{false};
  std::mutex counters_mutex_;  ///< guards the counters and figures below
  std::uint64_t frames_in_ = 0, frames_dropped_busy_ = 0, dropped_at_last_diagnosis_ = 0;
  RollingSamples latency_ms_;
  EventRate input_rate_;
  dypho_slam::MaskStatus last_status_;
  std::thread worker_;
  std::unique_ptr<rc::NodeletDiagnostics> diagnostics_;
  rc::ThrottledLog input_log_, degraded_log_;  ///< each kind of problem is named at once, then every 5 s
  ros::Subscriber tracking_sub_;
  ros::Subscriber moving_points_sub_;  ///< tracking's moving points (DynamicMaskOptions::moving_point_seeds)
  image_transport::Subscriber rendered_sub_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::Publisher mask_pub_, raw_pub_, raw_segment_pub_, consistency_pub_;
  ros::Publisher timing_pub_, status_pub_;
  image_transport::SubscriberFilter rgb_sub_, depth_sub_;
  message_filters::Subscriber<CameraInfo> info_sub_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy>> approx_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_;
  std::unique_ptr<rc::SyncWatchdog> watchdog_;
};

}  // namespace dypho::mask_ros

PLUGINLIB_EXPORT_CLASS(dypho::mask_ros::DynamicMaskNodelet, nodelet::Nodelet)
