/// TrackingNodelet: synchronised rgb + depth + camera_info (+ dynamic mask) in; pose, path, tf
/// (map -> odom -> camera, REP-105), tracking status (with the pose and its jump flags, which the
/// mask and mapping nodelets feed their motion models with), keyframes, keyframe correction
/// batches and timing out. All the work and its policy are in dypho::tracking::TrackingStage (the
/// same stage the in-process pipeline runs).

#include <filesystem>
#include <memory>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/KeyframeCorrections.h>
#include <dypho_slam/Reset.h>
#include <dypho_slam/SaveMap.h>
#include <dypho_slam/StageTiming.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <nav_msgs/Path.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <tf2_ros/transform_broadcaster.h>

#include "dypho/common/output_path.h"
#include "dypho/tracking/tracking_options_fields.h"
#include "dypho/tracking/tracking_stage.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/param_reader.h"
#include "dypho_ros/sync_watchdog.h"
#include "dypho_ros/throttled_log.h"

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
  int queue_size = 10;              ///< synchroniser queue [messages]
  double watchdog_s = 5.0;          ///< warn when no synchronised input for this long [s]
  /// where trajectory.txt is written on shutdown (empty = not on shutdown); ~save_trajectory
  /// writes only inside it (empty: inside $ROS_HOME/dypho, default ~/.ros/dypho)
  std::string output_dir;
  int max_path_length = 100000;     ///< path poses kept [poses]
};

std::uint8_t toStatusState(tracking::TrackingState state) {
  switch (state) {
    case tracking::TrackingState::kOk: return dypho_slam::TrackingStatus::OK;
    case tracking::TrackingState::kLost: return dypho_slam::TrackingStatus::LOST;
    default: return dypho_slam::TrackingStatus::NOT_INITIALIZED;
  }
}

class TrackingNodelet : public nodelet::Nodelet {
  using Policy4 = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo, Image>;
  using Policy3 = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;

 public:
  /// A bad parameter must not take the manager down, nor vanish: it is logged as FATAL
  /// with the reason and this nodelet stays idle (nothing advertised or subscribed) until it is
  /// restarted with a fixed configuration.
  void onInit() override {
    try {
      start();
    } catch (const std::exception& e) {
      NODELET_FATAL_STREAM("not started: " << e.what() << " (this nodelet stays idle; fix the configuration and restart it)");
    }
  }

  void start() {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    // 1. Parameters.
    rc::RosParamReader reader(pnh);
    tracking::TrackingOptions options;
    tracking::visitOptions(options, reader);
    reader("map_frame", params_.map_frame, "");
    reader("odom_frame", params_.odom_frame, "");
    reader("camera_frame", params_.camera_frame, "");
    reader("publish_tf", params_.publish_tf, "");
    reader("use_mask", params_.use_mask, "");
    reader("queue_size", params_.queue_size, "");
    reader("watchdog_s", params_.watchdog_s, "");
    reader("output_dir", params_.output_dir, "");
    reader("max_path_length", params_.max_path_length, "");
    reader.checkNoUnknownKeys();
    // Created now, so that the save at shutdown has somewhere to go (and a path that cannot be
    // created is a startup error, not a silent loss at the end of the run).
    if (!params_.output_dir.empty()) std::filesystem::create_directories(params_.output_dir);
    options.validate();
    NODELET_INFO_STREAM("tracking parameters:" << reader.summary());

    // 2. Core.
    stage_ = std::make_unique<tracking::TrackingStage>(options);

    // 3. Outputs.
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>("pose", 10);
    path_pub_ = nh.advertise<nav_msgs::Path>("path", 2, true);
    status_pub_ = nh.advertise<dypho_slam::TrackingStatus>("tracking_status", 10);
    keyframe_pub_ = nh.advertise<dypho_slam::Keyframe>("keyframe", 10);
    corrections_pub_ = nh.advertise<dypho_slam::KeyframeCorrections>("keyframe_corrections", 100);
    timing_pub_ = nh.advertise<dypho_slam::StageTiming>("tracking/timing", 10);
    reset_srv_ = pnh.advertiseService("reset", &TrackingNodelet::onReset, this);
    save_srv_ = pnh.advertiseService("save_trajectory", &TrackingNodelet::onSave, this);
    path_.header.frame_id = params_.map_frame;
    tf_broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();

    // 4. Inputs.
    it_ = std::make_unique<image_transport::ImageTransport>(nh);
    const int q = params_.queue_size;
    rgb_sub_.subscribe(*it_, "rgb/image", q);
    depth_sub_.subscribe(*it_, "depth/image", q);
    info_sub_.subscribe(nh, "rgb/camera_info", q);
    std::vector<std::string> topics{nh.resolveName("rgb/image"), nh.resolveName("depth/image"),
                                    nh.resolveName("rgb/camera_info")};
    if (params_.use_mask) {
      mask_sub_.subscribe(*it_, "mask", q);
      sync4_ = std::make_unique<message_filters::Synchronizer<Policy4>>(Policy4(q), rgb_sub_,
                                                                        depth_sub_, info_sub_, mask_sub_);
      sync4_->registerCallback(&TrackingNodelet::callback, this);
      topics.push_back(nh.resolveName("mask"));
    } else {
      sync3_ = std::make_unique<message_filters::Synchronizer<Policy3>>(Policy3(q), rgb_sub_,
                                                                        depth_sub_, info_sub_);
      sync3_->registerCallback(&TrackingNodelet::callbackNoMask, this);
    }
    watchdog_ = std::make_unique<rc::SyncWatchdog>(nh, getName(), topics, params_.watchdog_s,
                                                   /*has_approx_sync=*/false);
  }

  ~TrackingNodelet() override {
    if (params_.output_dir.empty() || !stage_) return;
    try {
      saveTrajectory(params_.output_dir);
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM("could not write the trajectory on shutdown: " << e.what());
    }
  }

 private:
  void callbackNoMask(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                      const sensor_msgs::CameraInfoConstPtr& info) {
    callback(rgb, depth, info, nullptr);
  }

  void callback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                const sensor_msgs::CameraInfoConstPtr& info, const sensor_msgs::ImageConstPtr& mask_msg) {
    watchdog_->tick();
    RgbdFrame frame;
    cv::Mat mask;
    try {
      frame = rc::toRgbdFrame(*rgb, *depth, *info);
      if (mask_msg) mask = rc::toMask(*mask_msg);
    } catch (const std::exception& e) {
      const std::string message = std::string("dropping frame: ") + e.what();
      if (input_log_.pass(message)) NODELET_ERROR_STREAM(message);
      return;
    }
    tracking::TrackingOutput out;
    try {
      out = stage_->process(frame, mask);
    } catch (const std::exception& e) {  // never let a core error reach the manager's thread
      const std::string message = std::string("tracking failed on this frame, dropped: ") + e.what();
      if (input_log_.pass(message)) NODELET_ERROR_STREAM(message);
      return;
    }
    if (out.dropped) {  // repeated or late stamp: nothing to publish for it
      if (input_log_.pass(out.result.message)) NODELET_WARN_STREAM(out.result.message);
      return;
    }
    publish(out, rgb->header);
  }

  void publish(const tracking::TrackingOutput& out, const std_msgs::Header& header) {
    const tracking::TrackingResult& result = out.result;
    const std::string camera_frame = params_.camera_frame.empty() ? header.frame_id : params_.camera_frame;
    if (out.restarted) NODELET_WARN_STREAM("time jumped backwards (bag restarted?): tracking and path restart");
    auto status = boost::make_shared<dypho_slam::TrackingStatus>();
    status->header = header;
    status->header.frame_id = camera_frame;
    status->state = toStatusState(result.state);
    status->is_keyframe = result.is_keyframe;
    status->num_features = result.num_features;
    status->num_inliers = result.num_inliers;
    status->masked_fraction = static_cast<float>(result.masked_fraction);
    status->message = result.message;
    status->T_world_camera = rc::toPoseMsg(out.pose.T_world_camera);
    status->trusted = out.pose.trusted;
    status->anchored = out.pose.anchored;
    status->discontinuous = out.pose.discontinuous;
    status->restarted = out.restarted;
    status_pub_.publish(status);
    if (result.state != tracking::TrackingState::kOk) {
      const std::string message = std::string("tracking ") + tracking::toString(result.state) + ": " + result.message;
      if (state_log_.pass(message)) NODELET_WARN_STREAM(message);
    } else if (result.relocalized || result.loop_closed) {
      NODELET_INFO_STREAM("tracking: " << result.message);
    }
    publishTiming(result, header);
    publishCorrections(out.corrections(), header.stamp);
    // Never publish a pose we do not trust, nor one not anchored to the map (re-initialised).
    if (!out.pose.trusted || !out.pose.anchored) return;
    auto pose = boost::make_shared<geometry_msgs::PoseStamped>();
    pose->header.stamp = header.stamp;
    pose->header.frame_id = params_.map_frame;
    pose->pose = rc::toPoseMsg(result.T_world_camera);
    pose_pub_.publish(pose);
    publishPath(*pose, result.is_keyframe || result.loop_closed || out.restarted);
    if (params_.publish_tf) publishTf(result, header.stamp, camera_frame);
    if (result.keyframe) keyframe_pub_.publish(rc::toKeyframeMsg(*result.keyframe, camera_frame));
  }

  /// The path of trusted poses; redrawn from the final poses when keyframes moved (local BA,
  /// loop closure), else extended by `pose`.
  void publishPath(const geometry_msgs::PoseStamped& pose, bool redraw) {
    path_.header.stamp = pose.header.stamp;
    if (redraw) {
      path_.poses.clear();
      for (const auto& [stamp_ns, T_world_camera] : stage_->trackedPath(static_cast<std::size_t>(params_.max_path_length))) {
        geometry_msgs::PoseStamped p = pose;
        p.header.stamp = rc::toRosTime(stamp_ns);
        p.pose = rc::toPoseMsg(T_world_camera);
        path_.poses.push_back(p);
      }
    } else {
      path_.poses.push_back(pose);
      if (static_cast<int>(path_.poses.size()) > params_.max_path_length) path_.poses.erase(path_.poses.begin());
    }
    path_pub_.publish(path_);
  }

  /// Keyframe poses moved by local BA or loop closure, one batch, for mapping to re-anchor.
  void publishCorrections(const KeyframePoseCorrections& corrections, const ros::Time& stamp) {
    if (corrections.empty()) return;
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = params_.map_frame;
    corrections_pub_.publish(rc::toCorrectionsMsg(corrections, header));
  }

  static geometry_msgs::TransformStamped toTransform(const Eigen::Isometry3d& T, const ros::Time& stamp,
                                                     const std::string& parent, const std::string& child) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;
    t.header.frame_id = parent;
    t.child_frame_id = child;
    const geometry_msgs::Pose p = rc::toPoseMsg(T);
    t.transform.translation.x = p.position.x;
    t.transform.translation.y = p.position.y;
    t.transform.translation.z = p.position.z;
    t.transform.rotation = p.orientation;
    return t;
  }

  /// REP-105: map -> odom is the accumulated loop correction, odom -> camera the odometry.
  void publishTf(const tracking::TrackingResult& result, const ros::Time& stamp,
                 const std::string& camera_frame) {
    const Eigen::Isometry3d T_odom_camera = result.T_world_odom.inverse() * result.T_world_camera;
    if (!T_odom_camera.matrix().allFinite() || !result.T_world_odom.matrix().allFinite()) return;
    tf_broadcaster_->sendTransform(
        {toTransform(result.T_world_odom, stamp, params_.map_frame, params_.odom_frame),
         toTransform(T_odom_camera, stamp, params_.odom_frame, camera_frame)});
  }

  void publishTiming(const tracking::TrackingResult& result, const std_msgs::Header& header) {
    dypho_slam::StageTiming timing;
    timing.header = header;
    timing.node = "tracking";
    timing.stages = {"features", "matching", "pnp", "refine", "local_ba", "loop", "relocalization"};
    timing.ms = {static_cast<float>(result.times.features), static_cast<float>(result.times.matching),
                 static_cast<float>(result.times.pnp), static_cast<float>(result.times.refine),
                 static_cast<float>(result.times.local_ba), static_cast<float>(result.times.loop),
                 static_cast<float>(result.times.relocalization)};
    timing.total_ms = static_cast<float>(result.times.total);
    timing_pub_.publish(timing);
  }

  bool onReset(dypho_slam::Reset::Request&, dypho_slam::Reset::Response& res) {
    stage_->reset();
    path_.poses.clear();
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

  std::string saveTrajectory(const std::string& dir) {
    // trajectory.txt: tracked frames following the final poses of their keyframes (after local BA
    // and loop closure); trajectory_online.txt: the poses as published; keyframes.txt.
    const std::vector<std::string> paths = stage_->saveTrajectories(dir);
    NODELET_INFO_STREAM("wrote " << stage_->numFrames() << " poses to " << paths.front()
                                 << " (and trajectory_online.txt, keyframes.txt)");
    return paths.front();
  }

  TrackingRosParams params_;
  std::unique_ptr<tracking::TrackingStage> stage_;
  rc::ThrottledLog input_log_, state_log_;  ///< each kind of problem is named at once, then every 5 s
  nav_msgs::Path path_;  ///< the synchronised callback only
  ros::Publisher pose_pub_, path_pub_, status_pub_, keyframe_pub_, corrections_pub_, timing_pub_;
  ros::ServiceServer reset_srv_, save_srv_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_broadcaster_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter rgb_sub_, depth_sub_, mask_sub_;
  message_filters::Subscriber<CameraInfo> info_sub_;
  std::unique_ptr<message_filters::Synchronizer<Policy4>> sync4_;
  std::unique_ptr<message_filters::Synchronizer<Policy3>> sync3_;
  std::unique_ptr<rc::SyncWatchdog> watchdog_;
};

}  // namespace dypho::tracking_ros

PLUGINLIB_EXPORT_CLASS(dypho::tracking_ros::TrackingNodelet, nodelet::Nodelet)
