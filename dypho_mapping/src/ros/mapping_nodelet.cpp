/// GaussianMappingNodelet: keyframes (and corrected keyframe poses) in; the map as a coloured
/// PointCloud2 in the world frame out, plus save/reset services. Keyframes are handed to a worker
/// thread through a bounded queue so the ROS callbacks never block on map updates.

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/KeyframePose.h>
#include <dypho_slam/Reset.h>
#include <dypho_slam/SaveMap.h>
#include <nodelet/nodelet.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pluginlib/class_list_macros.hpp>
#include <sensor_msgs/PointCloud2.h>

#include "dypho/common/bounded_queue.h"
#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/keyframe_cloud_map.h"
#include "dypho/mapping/mapping_options_fields.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/param_reader.h"

namespace dypho::mapping_ros {

namespace rc = dypho::ros_conversions;

/// Frames, rates and queues of the nodelet (not part of the core options).
struct MappingRosParams {
  std::string map_frame = "map";     ///< frame of the published cloud (the tracking world frame)
  double publish_period_s = 1.0;     ///< cloud publication period [s] (only with subscribers)
  int keyframe_queue_size = 20;      ///< keyframes waiting for the worker before the oldest is dropped
  std::string output_dir;            ///< where save_map writes when the request names no folder
  bool use_gpu = true;               ///< use CUDA when built with it and a device exists
};

class GaussianMappingNodelet : public nodelet::Nodelet {
 public:
  ~GaussianMappingNodelet() override {
    if (queue_) queue_->shutdown();
    if (worker_.joinable()) worker_.join();
  }

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    // 1. Parameters.
    rc::RosParamReader reader(pnh);
    mapping::CloudMapOptions options;
    mapping::visitOptions(options, reader);
    reader("map_frame", params_.map_frame, "");
    reader("publish_period_s", params_.publish_period_s, "");
    reader("keyframe_queue_size", params_.keyframe_queue_size, "");
    reader("output_dir", params_.output_dir, "");
    reader("use_gpu", params_.use_gpu, "");
    reader.checkNoUnknownKeys();
    options.validate();
    NODELET_INFO_STREAM("mapping parameters:" << reader.summary());
    std::string device_message;
    const mapping::ComputeDevice device = mapping::selectComputeDevice(params_.use_gpu, &device_message);
    if (params_.use_gpu && device != mapping::ComputeDevice::kCuda) {
      NODELET_WARN_STREAM(device_message);
    } else {
      NODELET_INFO_STREAM(device_message);
    }

    // 2. Core and worker.
    map_ = std::make_unique<mapping::KeyframeCloudMap>(options);
    queue_ = std::make_unique<BoundedQueue<KeyframeConstPtr>>(params_.keyframe_queue_size);
    worker_ = std::thread([this] { work(); });

    // 3. Outputs.
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
    save_srv_ = pnh.advertiseService("save_map", &GaussianMappingNodelet::onSave, this);
    reset_srv_ = pnh.advertiseService("reset", &GaussianMappingNodelet::onReset, this);
    timer_ = nh.createWallTimer(ros::WallDuration(params_.publish_period_s),
                                [this](const ros::WallTimerEvent&) { publishCloud(); });

    // 4. Inputs.
    keyframe_sub_ = nh.subscribe("keyframe", 10, &GaussianMappingNodelet::onKeyframe, this);
    pose_sub_ = nh.subscribe("keyframe_pose", 100, &GaussianMappingNodelet::onKeyframePose, this);
  }

 private:
  void onKeyframe(const dypho_slam::KeyframeConstPtr& msg) {
    try {
      auto keyframe = std::make_shared<Keyframe>(rc::toKeyframe(*msg));
      if (!queue_->push(std::move(keyframe))) {
        NODELET_WARN_STREAM_THROTTLE(5.0, "mapping is behind: dropped the oldest queued keyframe ("
                                              << queue_->numDropped() << " so far); raise "
                                              << "~keyframe_queue_size or ~pixel_stride");
      }
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM_THROTTLE(5.0, "skipping keyframe " << msg->id << ": " << e.what());
    }
  }

  void onKeyframePose(const dypho_slam::KeyframePoseConstPtr& msg) {
    const Eigen::Isometry3d T = rc::toIsometry(msg->T_world_camera);
    if (!T.matrix().allFinite()) return;
    std::lock_guard<std::mutex> lock(map_mutex_);
    if (map_->updateKeyframePose(msg->id, T)) changed_ = true;
  }

  void work() {
    while (auto keyframe = queue_->pop()) {
      std::lock_guard<std::mutex> lock(map_mutex_);
      try {
        map_->addKeyframe(**keyframe);
        changed_ = true;
      } catch (const std::exception& e) {
        NODELET_ERROR_STREAM("skipping keyframe " << (*keyframe)->id << ": " << e.what());
      }
    }
  }

  void publishCloud() {
    if (!changed_ || cloud_pub_.getNumSubscribers() == 0) return;
    pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud;
    {
      std::lock_guard<std::mutex> lock(map_mutex_);
      cloud = map_->buildCloud();
      changed_ = false;
    }
    auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
    pcl::toROSMsg(*cloud, *msg);
    msg->header.frame_id = params_.map_frame;
    msg->header.stamp = ros::Time::now();
    cloud_pub_.publish(msg);
  }

  bool onSave(dypho_slam::SaveMap::Request& req, dypho_slam::SaveMap::Response& res) {
    const std::string dir = req.directory.empty() ? (params_.output_dir.empty() ? "." : params_.output_dir)
                                                  : req.directory;
    const std::string path = dir + "/map.pcd";
    try {
      std::lock_guard<std::mutex> lock(map_mutex_);
      map_->savePcd(path);
      res.success = true;
      res.files.push_back(path);
      res.message = "wrote " + std::to_string(map_->numKeyframes()) + " keyframes to " + path;
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    return true;
  }

  bool onReset(dypho_slam::Reset::Request&, dypho_slam::Reset::Response& res) {
    queue_->clear();
    std::lock_guard<std::mutex> lock(map_mutex_);
    map_->reset();
    changed_ = true;
    res.success = true;
    res.message = "map cleared";
    return true;
  }

  MappingRosParams params_;
  std::unique_ptr<mapping::KeyframeCloudMap> map_;
  std::mutex map_mutex_;
  std::atomic<bool> changed_{false};
  std::unique_ptr<BoundedQueue<KeyframeConstPtr>> queue_;
  std::thread worker_;
  ros::Publisher cloud_pub_;
  ros::Subscriber keyframe_sub_, pose_sub_;
  ros::ServiceServer save_srv_, reset_srv_;
  ros::WallTimer timer_;
};

}  // namespace dypho::mapping_ros

PLUGINLIB_EXPORT_CLASS(dypho::mapping_ros::GaussianMappingNodelet, nodelet::Nodelet)
