/// GaussianMappingNodelet: keyframes (and corrected keyframe poses) in; the 3D Gaussian map and
/// the keyframe point cloud out. Keyframes go to the Gaussian mapper's worker thread through a
/// bounded queue (never blocks: the oldest is dropped when full); renders run on this nodelet's
/// own render thread, so no ROS callback waits for the optimiser.
///
/// Outputs: rendered/color (bgr8) and rendered/depth (32FC1 m) at the latest tracked pose;
/// rendered/depth_predicted (32FC1 m) at the constant-velocity prediction of the next camera pose,
/// header stamp = the predicted stamp of that next frame (last stamp + last frame interval), for the
/// mask module; gaussian_cloud (XYZRGB Gaussian centres) and map_cloud (keyframe points).
/// Services: ~save_map, ~load_map (a 3DGS PLY replaces the Gaussian map; also at start-up with
/// ~map_load_path), ~reset.

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/KeyframePose.h>
#include <dypho_slam/LoadMap.h>
#include <dypho_slam/Reset.h>
#include <dypho_slam/SaveMap.h>
#include <geometry_msgs/PoseStamped.h>
#include <nodelet/nodelet.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pluginlib/class_list_macros.hpp>
#include <sensor_msgs/PointCloud2.h>

#include "dypho/mapping/compute_device.h"
#include "dypho/mapping/gaussian_mapper.h"
#include "dypho/mapping/keyframe_cloud_map.h"
#include "dypho/mapping/mapping_options_fields.h"
#include "dypho_ros/conversions.h"
#include "dypho_ros/param_reader.h"

namespace dypho::mapping_ros {

namespace rc = dypho::ros_conversions;

/// Frames, rates and queues of the nodelet (not part of the core options).
struct MappingRosParams {
  std::string map_frame = "map";     ///< frame of the published clouds (the tracking world frame)
  double publish_period_s = 1.0;     ///< cloud publication period [s] (only with subscribers)
  double render_period_s = 0.2;      ///< minimum interval of rendered/color and rendered/depth [s]
  int keyframe_queue_size = 20;      ///< keyframes waiting for the worker before the oldest is dropped
  std::string output_dir;            ///< where save_map writes when the request names no folder
  std::string map_load_path;         ///< 3DGS PLY loaded at start-up (empty: start with an empty map)
  bool use_gpu = true;               ///< use CUDA when built with it and a device exists
  /// save_map first runs the mapper's final refinement (`final_refine_iterations` over all
  /// keyframes, GaussianMapper::finish(); blocks the call for that long, mapping goes on beside it)
  bool refine_before_save = true;
};

/// A pose to render at (the latest tracked pose and its predecessor).
struct RenderRequest {
  Eigen::Isometry3d T_world_camera;
  ros::Time stamp;
  std::optional<Eigen::Isometry3d> T_world_camera_prev;
  ros::Time stamp_prev;
};

class GaussianMappingNodelet : public nodelet::Nodelet {
 public:
  ~GaussianMappingNodelet() override {
    {
      std::lock_guard<std::mutex> lock(render_mutex_);
      stop_ = true;
    }
    render_cv_.notify_all();
    if (render_thread_.joinable()) render_thread_.join();
    if (gaussians_) gaussians_->stop();
  }

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    // 1. Parameters.
    rc::RosParamReader reader(pnh);
    mapping::MappingOptions options;
    mapping::visitOptions(options, reader);
    reader("map_frame", params_.map_frame, "");
    reader("publish_period_s", params_.publish_period_s, "");
    reader("render_period_s", params_.render_period_s, "");
    reader("keyframe_queue_size", params_.keyframe_queue_size, "");
    reader("output_dir", params_.output_dir, "");
    reader("map_load_path", params_.map_load_path, "");
    reader("use_gpu", params_.use_gpu, "");
    reader("refine_before_save", params_.refine_before_save, "");
    reader.checkNoUnknownKeys();
    options.validate();
    NODELET_INFO_STREAM("mapping parameters:" << reader.summary());
    std::string device_message;
    const mapping::ComputeDevice device = mapping::selectComputeDevice(params_.use_gpu, &device_message);
    if (params_.use_gpu && device != mapping::ComputeDevice::kCuda) {
      NODELET_WARN_STREAM(device_message << " (the Gaussian rasterizer runs on the CPU)");
    } else {
      NODELET_INFO_STREAM(device_message);
    }

    // 2. Cores and threads.
    cloud_map_ = std::make_unique<mapping::KeyframeCloudMap>(options.cloud);
    gaussians_ = std::make_unique<mapping::GaussianMapper>(options.gaussian);
    gaussians_->setMessageSink([this](const std::string& m) { NODELET_WARN_STREAM_THROTTLE(5.0, m); });
    if (!params_.map_load_path.empty()) {
      // A bad file is reported and mapping starts empty (the nodelet manager keeps running).
      const LoadOutcome r = loadMap(params_.map_load_path);
      if (r.success) {
        NODELET_INFO_STREAM(r.message);
      } else {
        NODELET_ERROR_STREAM("~map_load_path: " << r.message << "; starting with an empty map");
      }
    }
    gaussians_->start(static_cast<std::size_t>(std::max(1, params_.keyframe_queue_size)));
    render_thread_ = std::thread([this] { renderLoop(); });

    // 3. Outputs.
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
    gaussian_cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("gaussian_cloud", 1, true);
    color_pub_ = nh.advertise<sensor_msgs::Image>("rendered/color", 1);
    depth_pub_ = nh.advertise<sensor_msgs::Image>("rendered/depth", 1);
    predicted_pub_ = nh.advertise<sensor_msgs::Image>("rendered/depth_predicted", 1);
    save_srv_ = pnh.advertiseService("save_map", &GaussianMappingNodelet::onSave, this);
    reset_srv_ = pnh.advertiseService("reset", &GaussianMappingNodelet::onReset, this);
    load_srv_ = pnh.advertiseService("load_map", &GaussianMappingNodelet::onLoad, this);
    timer_ = nh.createWallTimer(ros::WallDuration(params_.publish_period_s),
                                [this](const ros::WallTimerEvent&) { publishClouds(); });

    // 4. Inputs.
    keyframe_sub_ = nh.subscribe("keyframe", 10, &GaussianMappingNodelet::onKeyframe, this);
    pose_sub_ = nh.subscribe("keyframe_pose", 100, &GaussianMappingNodelet::onKeyframePose, this);
    camera_pose_sub_ = nh.subscribe("pose", 5, &GaussianMappingNodelet::onCameraPose, this);
  }

 private:
  void onKeyframe(const dypho_slam::KeyframeConstPtr& msg) {
    try {
      auto keyframe = std::make_shared<Keyframe>(rc::toKeyframe(*msg));
      {
        std::lock_guard<std::mutex> lock(cloud_mutex_);
        cloud_map_->addKeyframe(*keyframe);  // point cloud: cheap (strided unprojection)
      }
      {
        std::lock_guard<std::mutex> lock(render_mutex_);
        camera_ = keyframe->frame.camera;
        frame_id_ = msg->header.frame_id;
      }
      if (!gaussians_->enqueueKeyframe(std::move(keyframe), /*block_when_full=*/false)) {
        NODELET_WARN_STREAM_THROTTLE(5.0, "Gaussian mapping is behind: dropped the oldest queued keyframe ("
                                              << gaussians_->stats().dropped_keyframes << " so far); raise "
                                              << "~keyframe_queue_size or lower ~iterations_per_keyframe");
      }
      changed_ = true;
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM_THROTTLE(5.0, "skipping keyframe " << msg->id << ": " << e.what());
    }
  }

  void onKeyframePose(const dypho_slam::KeyframePoseConstPtr& msg) {
    const Eigen::Isometry3d T = rc::toIsometry(msg->T_world_camera);
    if (!T.matrix().allFinite()) return;
    {
      std::lock_guard<std::mutex> lock(cloud_mutex_);
      cloud_map_->updateKeyframePose(msg->id, T);
    }
    if (gaussians_->updateKeyframePose(msg->id, T)) changed_ = true;
  }

  void onCameraPose(const geometry_msgs::PoseStampedConstPtr& msg) {
    const Eigen::Isometry3d T = rc::toIsometry(msg->pose);
    if (!T.matrix().allFinite()) return;
    {
      std::lock_guard<std::mutex> lock(render_mutex_);
      RenderRequest r;
      r.T_world_camera = T;
      r.stamp = msg->header.stamp;
      if (last_pose_ && msg->header.stamp > last_pose_->stamp) {
        r.T_world_camera_prev = last_pose_->T_world_camera;
        r.stamp_prev = last_pose_->stamp;
      }
      last_pose_ = r;
      request_ = r;
    }
    render_cv_.notify_one();
  }

  /// Render thread: serves the newest request (older ones are superseded).
  void renderLoop() {
    ros::WallTime last_view = ros::WallTime(0);
    for (;;) {
      RenderRequest r;
      CameraIntrinsics camera;
      std::string frame_id;
      {
        std::unique_lock<std::mutex> lock(render_mutex_);
        render_cv_.wait(lock, [&] { return stop_ || request_.has_value(); });
        if (stop_) return;
        r = *request_;
        request_.reset();
        camera = camera_;
        frame_id = frame_id_;
      }
      if (!camera.valid() || gaussians_->stats().num_gaussians == 0) continue;
      try {
        if (r.T_world_camera_prev && predicted_pub_.getNumSubscribers() > 0) {
          // Constant velocity: the next step repeats the last one.
          const Eigen::Isometry3d step = r.T_world_camera_prev->inverse() * r.T_world_camera;
          std_msgs::Header header;
          header.stamp = r.stamp + (r.stamp - r.stamp_prev);
          header.frame_id = frame_id;
          predicted_pub_.publish(rc::toImageMsg(gaussians_->renderDepth(r.T_world_camera * step, camera), "32FC1", header));
        }
        const bool want_view = color_pub_.getNumSubscribers() > 0 || depth_pub_.getNumSubscribers() > 0;
        if (want_view && (ros::WallTime::now() - last_view).toSec() >= params_.render_period_s) {
          last_view = ros::WallTime::now();
          const mapping::RenderedView v = gaussians_->render(r.T_world_camera, camera);
          std_msgs::Header header;
          header.stamp = r.stamp;
          header.frame_id = frame_id;
          color_pub_.publish(rc::toImageMsg(v.bgr, "bgr8", header));
          depth_pub_.publish(rc::toImageMsg(v.depth_m, "32FC1", header));
        }
      } catch (const std::exception& e) {
        NODELET_ERROR_STREAM_THROTTLE(5.0, "rendering failed: " << e.what());
      }
    }
  }

  void publishClouds() {
    const std::int64_t iterations = gaussians_->stats().iterations;  // the optimiser changes the map too
    if (!changed_ && iterations == last_iterations_) return;
    changed_ = false;
    last_iterations_ = iterations;
    if (cloud_pub_.getNumSubscribers() > 0) {
      pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud;
      {
        std::lock_guard<std::mutex> lock(cloud_mutex_);
        cloud = cloud_map_->buildCloud();
      }
      auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
      pcl::toROSMsg(*cloud, *msg);
      msg->header.frame_id = params_.map_frame;
      msg->header.stamp = ros::Time::now();
      cloud_pub_.publish(msg);
    }
    if (gaussian_cloud_pub_.getNumSubscribers() > 0) {
      pcl::PointCloud<pcl::PointXYZRGB> cloud;
      for (const mapping::GaussianCentre& c : gaussians_->centres()) {
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
    const std::string dir = req.directory.empty() ? (params_.output_dir.empty() ? "." : params_.output_dir)
                                                  : req.directory;
    try {
      {
        std::lock_guard<std::mutex> lock(cloud_mutex_);
        cloud_map_->savePcd(dir + "/map.pcd");
      }
      if (params_.refine_before_save) gaussians_->finish();
      gaussians_->savePly(dir + "/map.ply");
      gaussians_->saveCentresPcd(dir + "/gaussian_centres.pcd");
      res.success = true;
      res.files = {dir + "/map.pcd", dir + "/map.ply", dir + "/gaussian_centres.pcd"};
      res.message = "wrote " + std::to_string(gaussians_->stats().num_gaussians) + " Gaussians and " +
                    std::to_string(cloud_map_->numKeyframes()) + " keyframe clouds to " + dir;
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
      const std::size_t n = gaussians_->loadPly(path, &note);
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

  bool onReset(dypho_slam::Reset::Request&, dypho_slam::Reset::Response& res) {
    {
      std::lock_guard<std::mutex> lock(cloud_mutex_);
      cloud_map_->reset();
    }
    gaussians_->reset();
    changed_ = true;
    res.success = true;
    res.message = "map cleared";
    return true;
  }

  MappingRosParams params_;
  std::unique_ptr<mapping::KeyframeCloudMap> cloud_map_;
  std::mutex cloud_mutex_;
  std::unique_ptr<mapping::GaussianMapper> gaussians_;
  std::atomic<bool> changed_{false};
  std::int64_t last_iterations_ = -1;  ///< timer thread only
  // Render thread state (render_mutex_).
  std::mutex render_mutex_;
  std::condition_variable render_cv_;
  std::optional<RenderRequest> request_, last_pose_;
  CameraIntrinsics camera_;
  std::string frame_id_;
  bool stop_ = false;
  std::thread render_thread_;
  ros::Publisher cloud_pub_, gaussian_cloud_pub_, color_pub_, depth_pub_, predicted_pub_;
  ros::Subscriber keyframe_sub_, pose_sub_, camera_pose_sub_;
  ros::ServiceServer save_srv_, reset_srv_, load_srv_;
  ros::WallTimer timer_;
};

}  // namespace dypho::mapping_ros

PLUGINLIB_EXPORT_CLASS(dypho::mapping_ros::GaussianMappingNodelet, nodelet::Nodelet)
