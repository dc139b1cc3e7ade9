/// Live-camera rostest: live_camera.launch (its camera:= topic layout, no sim time, as a user runs
/// it next to a driver) fed by a bag in the driver's topic names and encodings, played at 1x
/// (30 Hz). Checks that the input really is a 30 Hz stream in those encodings, the fraction of
/// the input frames that got a trusted pose, and the ATE of the published poses against the
/// synthetic ground truth.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <dypho_slam/MaskStatus.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include "dypho/common/trajectory_io.h"
#include "dypho/tools/evaluation.h"
#include "input_timing.h"
#include "player_start.h"

namespace DYPHO_UNITY_ID {

struct Recorder {
  std::mutex mutex;
  std::vector<double> rgb_stamps_s, rgb_wall_s;  ///< colour frames seen (header stamp, arrival)
  std::set<std::string> rgb_encodings, depth_encodings;
  std::atomic<int> depth_frames{0};
  std::set<double> status_stamps_s;            ///< frames tracking answered (any state)
  std::set<double> trusted_stamps_s;           ///< tracking_status with trusted = true
  std::vector<dypho::StampedPose> trajectory;  ///< from `pose`
  std::set<std::string> pose_frames;
  dypho_slam::TrackingStatus last_status;  ///< its counters say where frames went
  dypho_slam::MaskStatus last_mask;
  ros::WallTime last_input = ros::WallTime(0), last_output = ros::WallTime(0);
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(LiveCamera, ThirtyHertzBagIsTrackedAccurately) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string gt_path, rgb_topic, depth_topic, depth_encoding;
  int frames = 0;
  double min_posed_fraction = 0, max_ate_m = 0;
  ASSERT_TRUE(pnh.getParam("groundtruth", gt_path));
  ASSERT_TRUE(pnh.getParam("frames", frames));
  ASSERT_TRUE(pnh.getParam("rgb_topic", rgb_topic));
  ASSERT_TRUE(pnh.getParam("depth_topic", depth_topic));
  ASSERT_TRUE(pnh.getParam("depth_encoding", depth_encoding));
  ASSERT_TRUE(pnh.getParam("min_posed_fraction", min_posed_fraction));
  ASSERT_TRUE(pnh.getParam("max_ate_m", max_ate_m));
  std::string bag;
  ASSERT_TRUE(pnh.getParam("bag", bag));
  dypho::test::InputTiming input_timing;  // played at 1x
  ASSERT_GT(frames, 30);
  Recorder rec;

  auto rgb_sub = nh.subscribe<sensor_msgs::Image>(rgb_topic, 100, [&](const sensor_msgs::ImageConstPtr& m) {
    std::lock_guard<std::mutex> lock(rec.mutex);
    rec.rgb_stamps_s.push_back(m->header.stamp.toSec());
    rec.rgb_wall_s.push_back(ros::WallTime::now().toSec());
    input_timing.add(m->header.stamp.toSec(), rec.rgb_wall_s.back());
    rec.rgb_encodings.insert(m->encoding);
    rec.last_input = ros::WallTime::now();
  });
  auto depth_sub = nh.subscribe<sensor_msgs::Image>(depth_topic, 100, [&](const sensor_msgs::ImageConstPtr& m) {
    std::lock_guard<std::mutex> lock(rec.mutex);
    rec.depth_encodings.insert(m->encoding);
    ++rec.depth_frames;
  });
  auto status_sub = nh.subscribe<dypho_slam::TrackingStatus>("/dypho/tracking_status", 100,
                                                             [&](const dypho_slam::TrackingStatusConstPtr& s) {
                                                               std::lock_guard<std::mutex> lock(rec.mutex);
                                                               rec.status_stamps_s.insert(s->header.stamp.toSec());
                                                               if (s->trusted)
                                                                 rec.trusted_stamps_s.insert(s->header.stamp.toSec());
                                                               rec.last_status = *s;
                                                               rec.last_output = ros::WallTime::now();
                                                             });
  auto mask_sub =
      nh.subscribe<dypho_slam::MaskStatus>("/dypho/mask/status", 100, [&](const dypho_slam::MaskStatusConstPtr& m) {
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.last_mask = *m;
      });
  auto pose_sub =
      nh.subscribe<geometry_msgs::PoseStamped>("/dypho/pose", 100, [&](const geometry_msgs::PoseStampedConstPtr& p) {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.linear() = Eigen::Quaterniond(p->pose.orientation.w, p->pose.orientation.x, p->pose.orientation.y,
                                        p->pose.orientation.z)
                         .toRotationMatrix();
        T.translation() << p->pose.position.x, p->pose.position.y, p->pose.position.z;
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.trajectory.push_back({p->header.stamp.toSec(), T});
        rec.pose_frames.insert(p->header.frame_id);
        rec.last_output = ros::WallTime::now();
      });

  ros::AsyncSpinner spinner(2);
  spinner.start();
  // The player starts paused and plays once the three nodelets are up (player_start.h).
  ASSERT_TRUE(
      dypho::test::resumePlayerOnceAdvertised({"/dypho/mask", "/dypho/tracking_status", "/dypho/map_cloud"}, bag));
  // Wait for the bag: all frames seen, or no input for 3 s after the first; then for the graph to
  // drain (no status or pose for 3 s). Bounded by the wall time the bag needs plus 25 s.
  const ros::WallTime start = ros::WallTime::now();
  const double limit_s = frames / 30.0 + 25.0;
  auto waited = [&] { return (ros::WallTime::now() - start).toSec(); };
  while (waited() < limit_s) {
    ros::WallDuration(0.2).sleep();
    std::lock_guard<std::mutex> lock(rec.mutex);
    const int seen = static_cast<int>(rec.rgb_stamps_s.size());
    if (seen >= frames || (seen > 0 && (ros::WallTime::now() - rec.last_input).toSec() > 3.0)) break;
  }
  while (waited() < limit_s) {
    ros::WallDuration(0.2).sleep();
    std::lock_guard<std::mutex> lock(rec.mutex);
    if ((ros::WallTime::now() - rec.last_output).toSec() > 3.0) break;
  }
  spinner.stop();
  std::lock_guard<std::mutex> lock(rec.mutex);

  // The input is the stream the launch file expects: the driver's encodings, 30 Hz in the stamps
  // and 30 Hz in wall time (the bag played at 1x).
  const int seen = static_cast<int>(rec.rgb_stamps_s.size());
  ASSERT_GE(seen, 2) << "no colour frames on " << rgb_topic << ": did the player start?";
  EXPECT_EQ(rec.rgb_encodings, std::set<std::string>{"rgb8"});
  EXPECT_EQ(rec.depth_encodings, std::set<std::string>{depth_encoding});
  std::vector<double> dt;
  for (std::size_t i = 1; i < rec.rgb_stamps_s.size(); ++i) dt.push_back(rec.rgb_stamps_s[i] - rec.rgb_stamps_s[i - 1]);
  const double stamp_rate_hz = 1.0 / median(dt);
  const double wall_rate_hz = (seen - 1) / (rec.rgb_wall_s.back() - rec.rgb_wall_s.front());
  std::cout << "live test: " << seen << " of " << frames << " colour frames seen (" << rec.depth_frames
            << " depth), stamps at " << stamp_rate_hz << " Hz, arriving at " << wall_rate_hz << " Hz\n";
  // The test node subscribed before it resumed the player, so it sees every frame.
  EXPECT_EQ(seen, frames);
  EXPECT_NEAR(stamp_rate_hz, 30.0, 0.1);
  // rosbag play keeps 1x within a few per cent even on a loaded machine; 20 % means it did not.
  EXPECT_NEAR(wall_rate_hz, 30.0, 6.0);

  // Frames posed: input frames whose tracking_status carried a trusted pose, and poses published
  // on `pose` (the same frames, unless a segment was not anchored). The denominator is every
  // frame in the bag: a frame the synchroniser dropped because the graph fell behind counts as
  // not posed.
  std::set<double> pose_stamps;
  for (const auto& p : rec.trajectory) pose_stamps.insert(p.stamp_s);
  const double trusted_fraction = static_cast<double>(rec.trusted_stamps_s.size()) / frames;
  const double posed_fraction = static_cast<double>(pose_stamps.size()) / frames;
  std::cout << "live test: tracking answered " << rec.status_stamps_s.size() << " of " << frames << " frames ("
            << frames - static_cast<int>(rec.status_stamps_s.size())
            << " dropped before tracking: the graph fell behind), trusted pose on " << rec.trusted_stamps_s.size()
            << " (" << 100.0 * trusted_fraction << " %), pose published for " << pose_stamps.size() << " ("
            << 100.0 * posed_fraction << " %)\n";
  // Where frames went, from the last statuses: the synchroniser's output (frames_in) against the
  // bag tells the frames lost in transport or in the subscriber queues; the tracking and mask
  // counters tell the frames their queues dropped; latency and tracking time tell how far behind.
  // Which frames went unanswered (indices in the bag), as ranges: a start-up stall and a slow
  // spell in the middle look different.
  std::string missing;
  for (std::size_t i = 0; i < rec.rgb_stamps_s.size(); ++i) {
    if (rec.status_stamps_s.count(rec.rgb_stamps_s[i]) > 0) continue;
    std::size_t j = i;
    while (j + 1 < rec.rgb_stamps_s.size() && rec.status_stamps_s.count(rec.rgb_stamps_s[j + 1]) == 0) ++j;
    missing += (missing.empty() ? "" : ", ") + std::to_string(i) + (j > i ? "-" + std::to_string(j) : "");
    i = j;
  }
  if (!missing.empty()) std::cout << "live test: frames not answered: " << missing << "\n";
  const auto& st = rec.last_status;
  const auto& ms = rec.last_mask;
  std::cout << "live test: tracking counters: " << st.frames_in << " in, " << st.frames_processed << " processed, "
            << st.frames_dropped << " dropped, " << st.frames_mask_carried << " with a carried mask, "
            << st.frames_without_mask << " without a mask, " << st.frames_caught_up << " caught up; latency p50 "
            << st.latency_p50_ms << " ms, p95 " << st.latency_p95_ms << " ms; tracking p50 " << st.tracking_p50_ms
            << " ms, p95 " << st.tracking_p95_ms << " ms\n"
            << "live test: mask counters: " << ms.frames_in << " in, " << ms.frames << " masked, "
            << ms.frames_dropped_busy << " skipped (newer frames waiting); latency p50 " << ms.latency_p50_ms
            << " ms, p95 " << ms.latency_p95_ms << " ms\n"
            << "live test " << input_timing.describe() << "\n";
  // Bound 99 % (min_posed_fraction in live_camera.test), the live path's goal: tracking pairs each
  // frame with its mask within a bounded wait and keeps up to 16 waiting frames, so at 1x on 2
  // cores every frame is answered (150 of 150 for both layouts on the 2-core VM). Frames missing
  // here were dropped before tracking (counted in tracking_status).
  EXPECT_GE(trusted_fraction, min_posed_fraction);
  EXPECT_GE(posed_fraction, min_posed_fraction);
  EXPECT_EQ(rec.pose_frames, std::set<std::string>{"map"});

  // Accuracy of the published (online) poses against the generator's ground truth.
  const auto gt = dypho::readTumTrajectory(gt_path);
  ASSERT_GE(rec.trajectory.size(), 10u);
  const auto ate = dypho::tools::computeAte(rec.trajectory, gt);
  std::cout << "live test: ATE RMSE " << ate.rmse_m * 100 << " cm over " << ate.num_pairs << " poses (bound "
            << max_ate_m * 100 << " cm)\n";
  EXPECT_EQ(ate.num_pairs, rec.trajectory.size()) << "every pose must have ground truth at its stamp";
  EXPECT_LT(ate.rmse_m, max_ate_m);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_live_camera");
  return RUN_ALL_TESTS();
}
