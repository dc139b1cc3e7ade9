/// DynamicMaskNodelet: synchronised rgb + depth + camera_info in, dynamic mask (mono8, 255 =
/// dynamic) out. All the work is in dypho::mask::DynamicMasker. Optional inputs, never waited
/// for: tracking `pose` (PoseStamped; the last two give the constant-velocity prediction
/// T_prev_cur) and mapping `rendered/depth_predicted` (32FC1, the map's depth at the predicted
/// pose; used when its stamp is within 0.1 s of the frame).

#include <deque>
#include <memory>
#include <mutex>
#include <optional>

#include <dypho_slam/StageTiming.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <geometry_msgs/PoseStamped.h>
#include <sensor_msgs/image_encodings.h>

#include "dypho/mask/dynamic_masker.h"
#include "dypho/mask/mask_options_fields.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/param_reader.h"
#include "dypho_ros/sync_watchdog.h"

namespace dypho::mask_ros {

namespace rc = dypho::ros_conversions;
using sensor_msgs::CameraInfo;
using sensor_msgs::Image;

class DynamicMaskNodelet : public nodelet::Nodelet {
  using ApproxPolicy = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;
  using ExactPolicy = message_filters::sync_policies::ExactTime<Image, Image, CameraInfo>;

 public:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    // 1. Parameters.
    rc::RosParamReader reader(pnh);
    mask::DynamicMaskOptions options;
    mask::visitOptions(options, reader);
    int queue_size = 10;
    bool approx_sync = true;
    double watchdog_s = 5.0;
    reader("queue_size", queue_size, "synchroniser queue length [messages]");
    reader("approx_sync", approx_sync, "approximate-time sync of rgb/depth/camera_info");
    reader("watchdog_s", watchdog_s, "warn when no input arrived for this long [s]; 0 = off");
    reader.checkNoUnknownKeys();
    options.validate();
    NODELET_INFO_STREAM("dynamic mask parameters:" << reader.summary());

    // 2. Core.
    masker_ = std::make_unique<mask::DynamicMasker>(options);
    if (options.yolo.model_path.empty()) {
      NODELET_INFO_STREAM(masker_->segmentStatus());
    } else if (!masker_->segmentReady()) {
      NODELET_WARN_STREAM(masker_->segmentStatus());  // once; flow + background keep working
    } else {
      NODELET_INFO_STREAM(masker_->segmentStatus());
    }

    // 3. Outputs.
    it_ = std::make_unique<image_transport::ImageTransport>(nh);
    mask_pub_ = it_->advertise("mask", 5);
    raw_pub_ = it_->advertise("mask/raw_flow", 2);
    raw_segment_pub_ = it_->advertise("mask/raw_segment", 2);
    consistency_pub_ = it_->advertise("mask/raw_consistency", 2);
    timing_pub_ = nh.advertise<dypho_slam::StageTiming>("mask/timing", 10);

    // 4. Inputs.
    rgb_sub_.subscribe(*it_, "rgb/image", queue_size);
    depth_sub_.subscribe(*it_, "depth/image", queue_size);
    info_sub_.subscribe(nh, "rgb/camera_info", queue_size);
    pose_sub_ = nh.subscribe("pose", 10, &DynamicMaskNodelet::poseCallback, this);
    rendered_sub_ = it_->subscribe("rendered/depth_predicted", 2, &DynamicMaskNodelet::renderedCallback, this);
    if (approx_sync) {
      approx_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy>>(
          ApproxPolicy(queue_size), rgb_sub_, depth_sub_, info_sub_);
      approx_->registerCallback(&DynamicMaskNodelet::callback, this);
    } else {
      exact_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(
          ExactPolicy(queue_size), rgb_sub_, depth_sub_, info_sub_);
      exact_->registerCallback(&DynamicMaskNodelet::callback, this);
    }
    watchdog_ = std::make_unique<rc::SyncWatchdog>(
        nh, getName(),
        std::vector<std::string>{nh.resolveName("rgb/image"), nh.resolveName("depth/image"),
                                 nh.resolveName("rgb/camera_info")},
        watchdog_s);
  }

 private:
  void callback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                const sensor_msgs::CameraInfoConstPtr& info) {
    watchdog_->tick();
    RgbdFrame frame;
    try {
      frame = rc::toRgbdFrame(*rgb, *depth, *info);
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM_THROTTLE(5.0, "dropping frame: " << e.what());
      return;
    }
    const mask::MaskResult result = masker_->compute(frame, currentPrior(rgb->header.stamp));
    if (result.degraded && !result.message.empty()) {
      NODELET_WARN_STREAM_THROTTLE(5.0, "mask degraded: " << result.message);
    }
    mask_pub_.publish(rc::toImageMsg(result.mask, sensor_msgs::image_encodings::MONO8, rgb->header));
    publishIfWanted(raw_pub_, result.raw_flow_mask, rgb->header);
    publishIfWanted(raw_segment_pub_, result.raw_segment_mask, rgb->header);
    publishIfWanted(consistency_pub_, result.consistency_mask, rgb->header);
    dypho_slam::StageTiming timing;
    timing.header = rgb->header;
    timing.node = "mask";
    timing.stages = {"flow", "segment", "background"};
    timing.ms = {static_cast<float>(result.flow_ms), static_cast<float>(result.segment_ms),
                 static_cast<float>(result.background_ms)};
    timing.total_ms = static_cast<float>(result.total_ms);
    timing_pub_.publish(timing);
  }

  void publishIfWanted(image_transport::Publisher& pub, const cv::Mat& image, const std_msgs::Header& header) {
    if (pub.getNumSubscribers() > 0 && !image.empty()) {
      pub.publish(rc::toImageMsg(image, sensor_msgs::image_encodings::MONO8, header));
    }
  }

  /// Keeps the last two tracked poses (the callback never blocks the mask output).
  void poseCallback(const geometry_msgs::PoseStampedConstPtr& msg) {
    std::lock_guard<std::mutex> lock(prior_mutex_);
    if (!poses_.empty() && msg->header.stamp <= poses_.back().first) poses_.clear();  // restart
    poses_.emplace_back(msg->header.stamp, rc::toIsometry(msg->pose));
    while (poses_.size() > 2) poses_.pop_front();
  }

  void renderedCallback(const sensor_msgs::ImageConstPtr& msg) {
    cv::Mat depth;
    try {
      depth = rc::toDepthMetres(*msg);
    } catch (const std::exception& e) {
      NODELET_WARN_STREAM_THROTTLE(10.0, "ignoring rendered/depth_predicted: " << e.what());
      return;
    }
    std::lock_guard<std::mutex> lock(prior_mutex_);
    rendered_ = depth.clone();  // the conversion may share the message buffer
    rendered_stamp_ = msg->header.stamp;
  }

  /// Constant velocity: T_prev_cur = the last tracked step, when it is recent (< 1 s old).
  mask::MaskPrior currentPrior(const ros::Time& stamp) {
    mask::MaskPrior prior;
    std::lock_guard<std::mutex> lock(prior_mutex_);
    if (poses_.size() == 2 && std::abs((stamp - poses_.back().first).toSec()) < 1.0) {
      prior.T_prev_cur = poses_.front().second.inverse() * poses_.back().second;
    }
    if (!rendered_.empty() && std::abs((stamp - rendered_stamp_).toSec()) < 0.1) {
      prior.rendered_depth_m = rendered_;
    }
    return prior;
  }

  std::unique_ptr<mask::DynamicMasker> masker_;
  std::mutex prior_mutex_;
  std::deque<std::pair<ros::Time, Eigen::Isometry3d>> poses_;
  cv::Mat rendered_;
  ros::Time rendered_stamp_;
  ros::Subscriber pose_sub_;
  image_transport::Subscriber rendered_sub_;
  image_transport::Publisher raw_segment_pub_;
  image_transport::Publisher consistency_pub_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::Publisher mask_pub_;
  image_transport::Publisher raw_pub_;
  ros::Publisher timing_pub_;
  image_transport::SubscriberFilter rgb_sub_;
  image_transport::SubscriberFilter depth_sub_;
  message_filters::Subscriber<CameraInfo> info_sub_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy>> approx_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_;
  std::unique_ptr<rc::SyncWatchdog> watchdog_;
};

}  // namespace dypho::mask_ros

PLUGINLIB_EXPORT_CLASS(dypho::mask_ros::DynamicMaskNodelet, nodelet::Nodelet)
