/// rostest node for bad_input.test: publishes synthetic RGB-D frames to the three nodelets,
/// interleaved with bad messages, and checks the graph's answers (see bad_input.test).

#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include <cv_bridge/cv_bridge.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include "dypho/tools/synthetic_scene.h"

namespace DYPHO_UNITY_ID {

using dypho::tools::SynthFrame;

struct Observed {
  std::mutex mutex;
  std::atomic<int> poses{0}, masks{0}, statuses{0}, nan_poses{0}, restarts{0};
  std::vector<std::string> log;  ///< warnings and errors of the nodelets
};

class Feeder {
 public:
  explicit Feeder(ros::NodeHandle& nh)
      : rgb_(nh.advertise<sensor_msgs::Image>("/camera/rgb/image_color", 5)),
        depth_(nh.advertise<sensor_msgs::Image>("/camera/depth/image", 5)),
        info_(nh.advertise<sensor_msgs::CameraInfo>("/camera/rgb/camera_info", 5)) {}

  /// Publishes one frame; the three messages share `stamp`. Lets the nodelets work 0.12 s.
  void publish(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth, const sensor_msgs::CameraInfo& info) {
    rgb_.publish(rgb);
    depth_.publish(depth);
    info_.publish(info);
    ros::WallDuration(0.12).sleep();
  }

  bool connected() const {
    return rgb_.getNumSubscribers() > 0 && depth_.getNumSubscribers() > 0 && info_.getNumSubscribers() > 0;
  }

 private:
  ros::Publisher rgb_, depth_, info_;
};

std_msgs::Header header(double t_s) {
  std_msgs::Header h;
  h.stamp = ros::Time(t_s);
  h.frame_id = "camera_rgb_optical_frame";
  return h;
}

sensor_msgs::CameraInfo infoOf(const SynthFrame& f, double t_s) {
  sensor_msgs::CameraInfo info;
  info.header = header(t_s);
  info.width = static_cast<std::uint32_t>(f.frame.camera.width);
  info.height = static_cast<std::uint32_t>(f.frame.camera.height);
  info.K = {f.frame.camera.fx, 0, f.frame.camera.cx, 0, f.frame.camera.fy, f.frame.camera.cy, 0, 0, 1};
  info.distortion_model = "plumb_bob";
  info.D = {0, 0, 0, 0, 0};
  return info;
}

sensor_msgs::Image rgbOf(const SynthFrame& f, double t_s, const std::string& encoding = "bgr8") {
  cv::Mat image = f.frame.bgr;
  if (encoding == "rgb8") cv::cvtColor(f.frame.bgr, image, cv::COLOR_BGR2RGB);
  if (encoding == "mono8") cv::cvtColor(f.frame.bgr, image, cv::COLOR_BGR2GRAY);
  return *cv_bridge::CvImage(header(t_s), encoding, image).toImageMsg();
}

sensor_msgs::Image depthOf(const cv::Mat& depth_m, double t_s, bool millimetres = false) {
  if (!millimetres) return *cv_bridge::CvImage(header(t_s), "32FC1", depth_m).toImageMsg();
  cv::Mat mm;
  depth_m.convertTo(mm, CV_16UC1, 1000.0);
  return *cv_bridge::CvImage(header(t_s), "16UC1", mm).toImageMsg();
}

bool logMentions(Observed& obs, const std::string& needle) {
  std::lock_guard<std::mutex> lock(obs.mutex);
  for (const std::string& line : obs.log)
    if (line.find(needle) != std::string::npos) return true;
  return false;
}

TEST(BadInput, NodeletsNameEachProblemPublishNoNaNAndKeepServing) {
  ros::NodeHandle nh;
  Observed obs;
  auto is_nan_pose = [](const geometry_msgs::Pose& p) {
    return !std::isfinite(p.position.x) || !std::isfinite(p.position.y) || !std::isfinite(p.position.z) ||
           !std::isfinite(p.orientation.w) || !std::isfinite(p.orientation.x);
  };
  auto pose_sub =
      nh.subscribe<geometry_msgs::PoseStamped>("/dypho/pose", 100, [&](const geometry_msgs::PoseStampedConstPtr& p) {
        if (is_nan_pose(p->pose)) ++obs.nan_poses;
        ++obs.poses;
      });
  auto status_sub = nh.subscribe<dypho_slam::TrackingStatus>("/dypho/tracking_status", 100,
                                                             [&](const dypho_slam::TrackingStatusConstPtr& s) {
                                                               if (is_nan_pose(s->T_world_camera) && s->trusted)
                                                                 ++obs.nan_poses;
                                                               if (s->restarted) ++obs.restarts;
                                                               ++obs.statuses;
                                                             });
  auto mask_sub =
      nh.subscribe<sensor_msgs::Image>("/dypho/mask", 100, [&](const sensor_msgs::ImageConstPtr&) { ++obs.masks; });
  auto log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 500, [&](const rosgraph_msgs::LogConstPtr& m) {
    if (m->level < rosgraph_msgs::Log::WARN) return;
    std::lock_guard<std::mutex> lock(obs.mutex);
    obs.log.push_back(m->name + ": " + m->msg);
  });
  ros::AsyncSpinner spinner(2);
  spinner.start();

  Feeder feed(nh);
  const ros::WallTime wait_start = ros::WallTime::now();
  while (!feed.connected() && (ros::WallTime::now() - wait_start).toSec() < 30.0) ros::WallDuration(0.2).sleep();
  ASSERT_TRUE(feed.connected()) << "the nodelets did not subscribe within 30 s";
  ros::WallDuration(1.0).sleep();

  dypho::tools::SynthOptions so;
  so.frames = 120;
  so.people = 0;
  so.seed = 11;
  const dypho::tools::SyntheticScene scene(so);
  double t = 1000.0;
  int next_frame = 0;
  // Good frames, alternating the accepted encodings (bgr8/rgb8/mono8 colour; 32FC1 m/16UC1 mm depth).
  auto good = [&](int n) {
    const char* encodings[] = {"bgr8", "rgb8", "bgr8", "mono8"};
    for (int i = 0; i < n; ++i, ++next_frame) {
      const SynthFrame f = scene.render(next_frame);
      t += 1.0 / 30.0;
      feed.publish(rgbOf(f, t, encodings[i % 4]), depthOf(f.frame.depth_m, t, i % 2 == 1), infoOf(f, t));
    }
  };
  auto poses_after = [&](int n) {
    const int before = obs.poses;
    good(n);
    ros::WallDuration(1.0).sleep();
    return obs.poses - before;
  };
  ASSERT_GE(poses_after(15), 10) << "the graph does not track good frames";
  // The generator's camera_info has the OpenNI driver's nominal values (525 px, the image centre,
  // no distortion), as TUM's bags do: the nodelets point the camera_file argument out.
  EXPECT_TRUE(logMentions(obs, "camera_info holds nominal values")) << "nominal intrinsics not pointed out";

  const SynthFrame f = scene.render(next_frame);
  auto bad = [&](const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth, const sensor_msgs::CameraInfo& info) {
    feed.publish(rgb, depth, info);
  };
  // 1. Unsupported colour encoding.
  t += 1.0 / 30.0;
  {
    sensor_msgs::Image rgb = rgbOf(f, t);
    rgb.encoding = "yuv422";
    rgb.step = rgb.width * 2;
    rgb.data.resize(rgb.step * rgb.height);
    bad(rgb, depthOf(f.frame.depth_m, t), infoOf(f, t));
  }
  // 2. Unsupported depth encoding.
  t += 1.0 / 30.0;
  {
    cv::Mat d8(f.frame.depth_m.size(), CV_8UC1, cv::Scalar(3));
    bad(rgbOf(f, t), *cv_bridge::CvImage(header(t), "8UC1", d8).toImageMsg(), infoOf(f, t));
  }
  // 3. Depth and colour of different sizes.
  t += 1.0 / 30.0;
  {
    cv::Mat small;
    cv::resize(f.frame.depth_m, small, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
    bad(rgbOf(f, t), depthOf(small, t), infoOf(f, t));
  }
  // 4. camera_info all zero (an uncalibrated driver).
  t += 1.0 / 30.0;
  {
    sensor_msgs::CameraInfo zero;
    zero.header = header(t);
    bad(rgbOf(f, t), depthOf(f.frame.depth_m, t), zero);
  }
  // 5. NaN, zero and negative depth everywhere; 6. a black frame.
  for (float v : {std::numeric_limits<float>::quiet_NaN(), 0.f, -1.f}) {
    t += 1.0 / 30.0;
    bad(rgbOf(f, t), depthOf(cv::Mat(f.frame.depth_m.size(), CV_32FC1, cv::Scalar(v)), t), infoOf(f, t));
  }
  t += 1.0 / 30.0;
  {
    SynthFrame black = f;
    black.frame.bgr.setTo(cv::Scalar(0, 0, 0));
    bad(rgbOf(black, t), depthOf(f.frame.depth_m, t), infoOf(f, t));
  }
  ros::WallDuration(1.0).sleep();
  EXPECT_TRUE(logMentions(obs, "yuv422")) << "unsupported colour encoding not named";
  EXPECT_TRUE(logMentions(obs, "8UC1")) << "unsupported depth encoding not named";
  EXPECT_TRUE(logMentions(obs, "camera_info")) << "uncalibrated camera_info not named";
  EXPECT_TRUE(logMentions(obs, "320x240")) << "the size mismatch not named";
  EXPECT_TRUE(logMentions(obs, "no valid depth")) << "frames without valid depth not named";
  EXPECT_TRUE(logMentions(obs, "textureless or dark")) << "the black frame not named";
  // The graph still serves.
  EXPECT_GE(poses_after(20), 10) << "no poses after the bad frames";

  // 7. A repeated stamp, then a frame 0.2 s late (out of order): each dropped and named; tracking
  // does not restart and goes on.
  {
    const SynthFrame g = scene.render(next_frame);
    feed.publish(rgbOf(g, t), depthOf(g.frame.depth_m, t), infoOf(g, t));  // the last good frame's stamp
    const double late = t - 0.2;
    feed.publish(rgbOf(g, late), depthOf(g.frame.depth_m, late), infoOf(g, late));
  }
  ros::WallDuration(1.0).sleep();
  EXPECT_TRUE(logMentions(obs, "repeated stamp")) << "the repeated stamp was not named";
  EXPECT_TRUE(logMentions(obs, "out of order")) << "the late frame was not named";
  EXPECT_GE(poses_after(20), 10) << "no poses after the repeated and late frames";
  EXPECT_EQ(obs.restarts, 0) << "a repeated or late frame restarted tracking";

  // 8. Time jumps backwards (a looped bag): tracking restarts and goes on.
  t -= 30.0;
  EXPECT_GE(poses_after(20), 10) << "no poses after time jumped backwards";
  EXPECT_TRUE(logMentions(obs, "backwards")) << "the restart was not reported";
  EXPECT_EQ(obs.restarts, 1) << "the jump back was not a restart";

  // 9. Moving points (tracking -> mask) without x/y/z fields, then with data shorter than its
  // size says: ignored and named; the mask goes on.
  {
    ros::Publisher points = nh.advertise<sensor_msgs::PointCloud2>("/dypho/moving_points", 2);
    const ros::WallTime start = ros::WallTime::now();
    while (points.getNumSubscribers() == 0 && (ros::WallTime::now() - start).toSec() < 10.0)
      ros::WallDuration(0.1).sleep();
    ASSERT_GT(points.getNumSubscribers(), 0u) << "the mask nodelet does not subscribe to moving_points";
    sensor_msgs::PointCloud2 no_fields;
    no_fields.header = header(t);
    no_fields.width = 3;
    no_fields.height = 1;
    points.publish(no_fields);
    sensor_msgs::PointCloud2 short_data;
    short_data.header = header(t);
    sensor_msgs::PointCloud2Modifier(short_data).setPointCloud2FieldsByString(1, "xyz");
    sensor_msgs::PointCloud2Modifier(short_data).resize(4);
    short_data.data.resize(short_data.data.size() / 2);
    points.publish(short_data);
    const int masks_before = obs.masks;
    EXPECT_GE(poses_after(20), 10) << "no poses after the bad moving points";
    EXPECT_GT(obs.masks - masks_before, 10) << "the mask stopped after the bad moving points";
    EXPECT_TRUE(logMentions(obs, "no float32 field 'x'")) << "the cloud without fields was not named";
    EXPECT_TRUE(logMentions(obs, "data shorter")) << "the truncated cloud was not named";
  }

  EXPECT_EQ(obs.nan_poses, 0);
  EXPECT_GT(obs.masks, 40);
  std::lock_guard<std::mutex> lock(obs.mutex);
  std::cout << "bad input: " << obs.poses << " poses, " << obs.statuses << " statuses, " << obs.masks << " masks, "
            << obs.log.size() << " warnings/errors, e.g.:\n";
  for (std::size_t i = 0; i < obs.log.size() && i < 12; ++i) std::cout << "  " << obs.log[i] << "\n";
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bad_input");
  return RUN_ALL_TESTS();
}
