/// DynamicMaskNodelet: synchronised rgb + depth + camera_info in, dynamic mask (mono8, 255 =
/// dynamic) out. All the work is in dypho::mask::FlowMotionMasker.

#include <memory>

#include <dypho_slam/StageTiming.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <sensor_msgs/image_encodings.h>

#include "dypho/mask/flow_motion_masker.h"
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
    mask::FlowMaskOptions options;
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
    masker_ = std::make_unique<mask::FlowMotionMasker>(options);

    // 3. Outputs.
    it_ = std::make_unique<image_transport::ImageTransport>(nh);
    mask_pub_ = it_->advertise("mask", 5);
    raw_pub_ = it_->advertise("mask/raw_flow", 2);
    timing_pub_ = nh.advertise<dypho_slam::StageTiming>("mask/timing", 10);

    // 4. Inputs.
    rgb_sub_.subscribe(*it_, "rgb/image", queue_size);
    depth_sub_.subscribe(*it_, "depth/image", queue_size);
    info_sub_.subscribe(nh, "rgb/camera_info", queue_size);
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
    const mask::MaskResult result = masker_->compute(frame);
    if (result.degraded && !result.message.empty()) {
      NODELET_WARN_STREAM_THROTTLE(5.0, "mask degraded: " << result.message);
    }
    mask_pub_.publish(rc::toImageMsg(result.mask, sensor_msgs::image_encodings::MONO8, rgb->header));
    if (raw_pub_.getNumSubscribers() > 0 && !result.raw_flow_mask.empty()) {
      raw_pub_.publish(
          rc::toImageMsg(result.raw_flow_mask, sensor_msgs::image_encodings::MONO8, rgb->header));
    }
    dypho_slam::StageTiming timing;
    timing.header = rgb->header;
    timing.node = "mask";
    timing.stages = {"flow"};
    timing.ms = {static_cast<float>(result.flow_ms)};
    timing.total_ms = static_cast<float>(result.total_ms);
    timing_pub_.publish(timing);
  }

  std::unique_ptr<mask::FlowMotionMasker> masker_;
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
