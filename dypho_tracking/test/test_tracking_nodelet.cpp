/// rostest node for tracking_nodelet.test: the tracking nodelet alone on the synthetic bag
/// (30 Hz, played at rate 1.0) must publish pose, path, tf and keyframes at the input rate.

#include <atomic>
#include <fstream>
#include <mutex>
#include <string>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/SaveMap.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/transform_listener.h>

namespace DYPHO_UNITY_ID {

TEST(TrackingNodelet, PublishesPosePathTfAndKeyframesAtTheInputRate) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  int frames = 0;
  ASSERT_TRUE(pnh.getParam("frames", frames));
  std::mutex mutex;
  std::atomic<int> poses{0}, keyframes{0}, statuses{0}, nan_poses{0};
  std::size_t path_length = 0;
  ros::WallTime first_pose, last_pose = ros::WallTime::now();
  auto pose_sub =
      nh.subscribe<geometry_msgs::PoseStamped>("/dypho/pose", 100, [&](const geometry_msgs::PoseStampedConstPtr& p) {
        const auto& q = p->pose.orientation;
        const auto& t = p->pose.position;
        if (!std::isfinite(q.w + q.x + q.y + q.z + t.x + t.y + t.z)) ++nan_poses;
        std::lock_guard<std::mutex> lock(mutex);
        if (poses == 0) first_pose = ros::WallTime::now();
        last_pose = ros::WallTime::now();
        ++poses;
      });
  auto path_sub = nh.subscribe<nav_msgs::Path>("/dypho/path", 10, [&](const nav_msgs::PathConstPtr& p) {
    std::lock_guard<std::mutex> lock(mutex);
    path_length = p->poses.size();
  });
  auto kf_sub = nh.subscribe<dypho_slam::Keyframe>("/dypho/keyframe", 50,
                                                   [&](const dypho_slam::KeyframeConstPtr&) { ++keyframes; });
  auto status_sub = nh.subscribe<dypho_slam::TrackingStatus>(
      "/dypho/tracking_status", 100, [&](const dypho_slam::TrackingStatusConstPtr&) { ++statuses; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < 60.0) {
    ros::WallDuration(0.5).sleep();
    if (statuses >= frames) break;
    std::lock_guard<std::mutex> lock(mutex);
    if (poses > 0 && (ros::WallTime::now() - last_pose).toSec() > 5.0) break;
  }
  std::lock_guard<std::mutex> lock(mutex);
  const double span_s = (last_pose - first_pose).toSec();
  std::cout << "tracking nodelet: " << statuses << " statuses, " << poses << " poses, " << keyframes
            << " keyframes, path " << path_length << ", pose span " << span_s << " s for " << frames << " frames\n";
  // At the input rate: >= 90 % of the frames give a status and a pose (the synchroniser may drop
  // the first frames while subscriptions connect), and the poses span at most 1.3x the bag's
  // duration (frames / 30 Hz): a tracker slower than the input would fall behind and drop frames.
  EXPECT_GE(statuses, frames * 9 / 10);
  EXPECT_GE(poses, frames * 9 / 10);
  EXPECT_LE(span_s, 1.3 * frames / 30.0);
  EXPECT_EQ(nan_poses, 0);
  EXPECT_GE(keyframes, 2);
  EXPECT_GE(path_length, static_cast<std::size_t>(frames * 9 / 10));
  EXPECT_TRUE(tf_buffer.canTransform("map", "odom", ros::Time(0)));
  EXPECT_TRUE(tf_buffer.canTransform("odom", "dypho_camera", ros::Time(0)));
}

// ~save_trajectory writes inside ~output_dir only: a folder name is taken from there; a path
// that leaves it is refused with a message and nothing is written.
TEST(TrackingNodelet, SaveServiceWritesOnlyInsideTheOutputDirectory) {
  ros::NodeHandle pnh("~");
  std::string output_dir;
  ASSERT_TRUE(pnh.getParam("output_dir", output_dir));
  ASSERT_TRUE(ros::service::waitForService("/dypho/tracking/save_trajectory", ros::Duration(10.0)));
  dypho_slam::SaveMap inside;
  inside.request.directory = "run1";
  ASSERT_TRUE(ros::service::call("/dypho/tracking/save_trajectory", inside));
  EXPECT_TRUE(inside.response.success) << inside.response.message;
  ASSERT_FALSE(inside.response.files.empty());
  EXPECT_EQ(inside.response.files.front(), output_dir + "/run1/trajectory.txt");
  EXPECT_TRUE(std::ifstream(output_dir + "/run1/trajectory.txt").good());
  for (const std::string& outside : {std::string("../escaped"), std::string("/tmp/dypho_escaped")}) {
    dypho_slam::SaveMap srv;
    srv.request.directory = outside;
    ASSERT_TRUE(ros::service::call("/dypho/tracking/save_trajectory", srv));
    EXPECT_FALSE(srv.response.success) << outside;
    EXPECT_NE(srv.response.message.find("outside the output directory"), std::string::npos) << srv.response.message;
  }
  EXPECT_FALSE(std::ifstream(output_dir + "/../escaped/trajectory.txt").good());
  EXPECT_FALSE(std::ifstream("/tmp/dypho_escaped/trajectory.txt").good());
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_tracking_nodelet");
  return RUN_ALL_TESTS();
}
