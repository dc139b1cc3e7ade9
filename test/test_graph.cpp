/// Graph test (rostest): the mask, tracking and mapping nodelets on a synthetic bag.
/// Checks that every output flows and that the tracked trajectory matches the ground truth.

#include <atomic>
#include <mutex>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_listener.h>

#include "dypho/tools/evaluation.h"
#include "dypho/tools/trajectory_io.h"

namespace {

struct Recorder {
  std::mutex mutex;
  std::atomic<int> masks{0}, poses{0}, keyframes{0}, clouds{0}, statuses{0}, ok_statuses{0};
  std::atomic<int> mask_errors{0};
  std::atomic<std::size_t> cloud_points{0};
  std::vector<dypho::tools::StampedPose> trajectory;
  ros::WallTime last_pose = ros::WallTime::now();
};

TEST(GraphTest, OutputsFlowAndTrajectoryIsAccurate) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string gt_path;
  int frames = 0;
  ASSERT_TRUE(pnh.getParam("groundtruth", gt_path));
  ASSERT_TRUE(pnh.getParam("frames", frames));
  Recorder rec;

  auto mask_sub = nh.subscribe<sensor_msgs::Image>("/dypho/mask", 50, [&](const sensor_msgs::ImageConstPtr& m) {
    if (m->encoding != "mono8" || m->width == 0) ++rec.mask_errors;
    ++rec.masks;
  });
  auto pose_sub = nh.subscribe<geometry_msgs::PoseStamped>("/dypho/pose", 50, [&](const geometry_msgs::PoseStampedConstPtr& p) {
    EXPECT_EQ(p->header.frame_id, "map");
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(p->pose.orientation.w, p->pose.orientation.x,
                                    p->pose.orientation.y, p->pose.orientation.z).toRotationMatrix();
    T.translation() << p->pose.position.x, p->pose.position.y, p->pose.position.z;
    std::lock_guard<std::mutex> lock(rec.mutex);
    rec.trajectory.push_back({p->header.stamp.toSec(), T});
    rec.last_pose = ros::WallTime::now();
    ++rec.poses;
  });
  auto kf_sub = nh.subscribe<dypho_slam::Keyframe>("/dypho/keyframe", 50, [&](const dypho_slam::KeyframeConstPtr& k) {
    EXPECT_FALSE(k->keypoints.empty());
    EXPECT_EQ(k->mask.encoding, "mono8");
    ++rec.keyframes;
  });
  auto cloud_sub = nh.subscribe<sensor_msgs::PointCloud2>("/dypho/map_cloud", 5, [&](const sensor_msgs::PointCloud2ConstPtr& c) {
    rec.cloud_points = static_cast<std::size_t>(c->width) * c->height;
    ++rec.clouds;
  });
  auto status_sub = nh.subscribe<dypho_slam::TrackingStatus>("/dypho/tracking_status", 50, [&](const dypho_slam::TrackingStatusConstPtr& s) {
    ++rec.statuses;
    if (s->state == dypho_slam::TrackingStatus::OK) ++rec.ok_statuses;
  });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);

  ros::AsyncSpinner spinner(2);
  spinner.start();
  // Wait until the bag has played: all frames seen, or no new pose for 8 s after the first.
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < 120.0) {
    ros::WallDuration(0.5).sleep();
    if (rec.statuses >= frames) break;
    std::lock_guard<std::mutex> lock(rec.mutex);
    if (rec.poses > 0 && (ros::WallTime::now() - rec.last_pose).toSec() > 8.0) break;
  }
  ros::WallDuration(2.0).sleep();  // let the cloud timer fire once more

  // Every frame is processed by mask and tracking. Bound: the approximate-time synchroniser may
  // drop the first frames while subscriptions connect, so at least 90 % of the frames.
  EXPECT_GE(rec.masks, frames * 9 / 10);
  EXPECT_GE(rec.statuses, frames * 9 / 10);
  EXPECT_EQ(rec.mask_errors, 0);
  // Tracking is OK on nearly all frames of this easy sequence (first frame initialises).
  EXPECT_GE(rec.ok_statuses, frames * 8 / 10);
  EXPECT_GE(rec.keyframes, 2);
  EXPECT_GE(rec.clouds, 1);
  EXPECT_GT(rec.cloud_points, 1000u);
  EXPECT_TRUE(tf_buffer.canTransform("map", "dypho_camera", ros::Time(0)));

  // Accuracy: ATE (rigid alignment) against the generator's ground truth.
  const auto gt = dypho::tools::readTumTrajectory(gt_path);
  std::lock_guard<std::mutex> lock(rec.mutex);
  ASSERT_GE(rec.trajectory.size(), 10u);
  const auto ate = dypho::tools::computeAte(rec.trajectory, gt);
  std::cout << "graph test: " << rec.masks << " masks, " << rec.poses << " poses, "
            << rec.keyframes << " keyframes, " << rec.clouds << " clouds (" << rec.cloud_points
            << " points), ATE RMSE " << ate.rmse_m * 100 << " cm over " << ate.num_pairs
            << " poses\n";
  // Bound 1.5 cm: the same bag run in-process (dypho_run_dataset) gives 0.37 cm and this graph
  // test measured 0.38-0.47 cm. Unlike the in-process run it is not deterministic (which frames
  // the synchroniser drops depends on the load), hence the margin.
  EXPECT_LT(ate.rmse_m, 0.015);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_graph");
  return RUN_ALL_TESTS();
}
