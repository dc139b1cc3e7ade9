/// Graph test (rostest): the mask, tracking and mapping nodelets on a synthetic bag.
/// Checks that every output flows, that the tracked trajectory matches the ground truth, and
/// that the graph and the in-process pipeline (the same stages chained with direct calls, on the
/// same frames read from the sequence folder) give the same keyframes and trajectory, with R_d
/// (the depth rendered from the map) used by the mask in both.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include <dypho_slam/Keyframe.h>
#include <dypho_slam/MaskStatus.h>
#include <dypho_slam/TrackingStatus.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_listener.h>

#include "dypho/common/trajectory_io.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/evaluation.h"
#include "dypho/tools/frame_source.h"
#include "input_timing.h"
#include "player_start.h"

namespace DYPHO_UNITY_ID {

struct Recorder {
  std::mutex mutex;
  std::atomic<int> masks{0}, poses{0}, keyframes{0}, clouds{0}, statuses{0}, ok_statuses{0};
  std::atomic<int> mask_errors{0};
  /// geometry_msgs/PoseWithCovarianceStamped received, and those whose covariance is not a finite
  /// symmetric matrix with positive position variances in the map frame.
  std::atomic<int> covariances{0}, bad_covariances{0};
  std::vector<double> position_sigmas_m;  ///< sqrt of the largest position-variance diagonal entry
  std::atomic<std::size_t> cloud_points{0};
  std::vector<dypho::StampedPose> trajectory;
  std::vector<double> keyframe_stamps_s;
  dypho_slam::MaskStatus last_mask_status;
  dypho_slam::TrackingStatus last_status;
  ros::WallTime last_pose = ros::WallTime::now();
};

/// The in-process pipeline on the sequence folder: its online trajectory and keyframe stamps.
struct InProcessRun {
  std::vector<dypho::StampedPose> trajectory;
  std::vector<double> keyframe_stamps_s;
  std::size_t frames_with_rendered_depth = 0;
  std::size_t frames = 0;
};

InProcessRun runInProcess(const std::string& dataset, double background_tau) {
  using namespace dypho;
  const std::string config_dir = tools::defaultConfigDir();
  pipeline::PipelineOptions options = pipeline::loadPipelineOptions(config_dir, "");
  options.mask.background.tau = background_tau;  // as the launch file sets it for the mask nodelet
  const auto source = tools::openFrameSource(dataset, "", config_dir);
  pipeline::SlamPipeline slam(options);
  InProcessRun run;
  for (std::size_t i = 0; i < source->size(); ++i) {
    const pipeline::FrameReport r = slam.process(source->load(i).frame);
    if (r.tracking.state == tracking::TrackingState::kOk) {
      run.trajectory.push_back({timestampToSeconds(r.tracking.stamp_ns), r.tracking.T_world_camera});
    }
    if (r.tracking.is_keyframe) run.keyframe_stamps_s.push_back(timestampToSeconds(r.tracking.stamp_ns));
  }
  run.frames_with_rendered_depth = slam.mask().stats().frames_with_rendered_depth;
  run.frames = slam.mask().stats().frames;
  return run;
}

/// Share of `a`'s stamps that have a stamp of `b` within `tolerance_s`.
double sharedStamps(const std::vector<double>& a, const std::vector<double>& b, double tolerance_s) {
  if (a.empty()) return 0.0;
  std::size_t n = 0;
  for (double t : a) {
    for (double u : b) {
      if (std::abs(t - u) <= tolerance_s) {
        ++n;
        break;
      }
    }
  }
  return static_cast<double>(n) / static_cast<double>(a.size());
}

TEST(GraphTest, OutputsFlowAndTrajectoryIsAccurate) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string gt_path, dataset;
  int frames = 0;
  ASSERT_TRUE(pnh.getParam("groundtruth", gt_path));
  ASSERT_TRUE(pnh.getParam("dataset", dataset));
  ASSERT_TRUE(pnh.getParam("frames", frames));
  // background_tau > 0: R_d is on in the launch file (graph_rendered_depth.test) and its use is
  // checked; min_posed_fraction: the share of the input frames that must get a pose.
  double background_tau = 0.0, min_posed_fraction = 0.99;
  pnh.getParam("background_tau", background_tau);
  pnh.getParam("min_posed_fraction", min_posed_fraction);
  std::string bag;
  double rate = 1.0;
  ASSERT_TRUE(pnh.getParam("bag", bag));
  pnh.getParam("rate", rate);  // the player's -r
  Recorder rec;

  auto mask_sub = nh.subscribe<sensor_msgs::Image>("/dypho/mask", 50, [&](const sensor_msgs::ImageConstPtr& m) {
    if (m->encoding != "mono8" || m->width == 0) ++rec.mask_errors;
    ++rec.masks;
  });
  auto pose_sub =
      nh.subscribe<geometry_msgs::PoseStamped>("/dypho/pose", 50, [&](const geometry_msgs::PoseStampedConstPtr& p) {
        EXPECT_EQ(p->header.frame_id, "map");
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.linear() = Eigen::Quaterniond(p->pose.orientation.w, p->pose.orientation.x, p->pose.orientation.y,
                                        p->pose.orientation.z)
                         .toRotationMatrix();
        T.translation() << p->pose.position.x, p->pose.position.y, p->pose.position.z;
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.trajectory.push_back({p->header.stamp.toSec(), T});
        rec.last_pose = ros::WallTime::now();
        ++rec.poses;
      });
  auto covariance_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "/dypho/pose_with_covariance", 50, [&](const geometry_msgs::PoseWithCovarianceStampedConstPtr& p) {
        const Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> C(p->pose.covariance.data());
        const bool good =
            p->header.frame_id == "map" && C.allFinite() && C.isApprox(C.transpose()) && C.diagonal().minCoeff() > 0.0;
        ++rec.covariances;
        if (!good) ++rec.bad_covariances;
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.position_sigmas_m.push_back(std::sqrt(std::max({C(0, 0), C(1, 1), C(2, 2), 0.0})));
      });
  auto kf_sub = nh.subscribe<dypho_slam::Keyframe>("/dypho/keyframe", 50, [&](const dypho_slam::KeyframeConstPtr& k) {
    EXPECT_FALSE(k->keypoints.empty());
    EXPECT_EQ(k->mask.encoding, "mono8");
    std::lock_guard<std::mutex> lock(rec.mutex);
    rec.keyframe_stamps_s.push_back(k->header.stamp.toSec());
    ++rec.keyframes;
  });
  auto cloud_sub =
      nh.subscribe<sensor_msgs::PointCloud2>("/dypho/map_cloud", 5, [&](const sensor_msgs::PointCloud2ConstPtr& c) {
        rec.cloud_points = static_cast<std::size_t>(c->width) * c->height;
        ++rec.clouds;
      });
  auto status_sub = nh.subscribe<dypho_slam::TrackingStatus>("/dypho/tracking_status", 50,
                                                             [&](const dypho_slam::TrackingStatusConstPtr& s) {
                                                               ++rec.statuses;
                                                               if (s->state == dypho_slam::TrackingStatus::OK)
                                                                 ++rec.ok_statuses;
                                                               std::lock_guard<std::mutex> lock(rec.mutex);
                                                               rec.last_status = *s;
                                                             });
  auto mask_status_sub =
      nh.subscribe<dypho_slam::MaskStatus>("/dypho/mask/status", 50, [&](const dypho_slam::MaskStatusConstPtr& m) {
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.last_mask_status = *m;
      });
  dypho::test::InputTiming input_timing(rate);  // camera_info is small: its arrival times cost nothing
  auto info_sub = nh.subscribe<sensor_msgs::CameraInfo>(
      "/camera/rgb/camera_info", 200, [&](const sensor_msgs::CameraInfoConstPtr& i) {
        input_timing.add(i->header.stamp.toSec(), ros::WallTime::now().toSec());
      });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);

  ros::AsyncSpinner spinner(2);
  spinner.start();
  // The player starts paused and plays once all three nodelets are up (player_start.h).
  ASSERT_TRUE(
      dypho::test::resumePlayerOnceAdvertised({"/dypho/mask", "/dypho/tracking_status", "/dypho/map_cloud"}, bag));
  // Wait until the bag has played: all frames seen, or no new pose for 8 s after the first.
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < 120.0) {
    ros::WallDuration(0.5).sleep();
    if (rec.statuses >= frames) break;
    std::lock_guard<std::mutex> lock(rec.mutex);
    if (rec.poses > 0 && (ros::WallTime::now() - rec.last_pose).toSec() > 8.0) break;
  }
  ros::WallDuration(2.0).sleep();  // let the cloud timer fire once more

  // graph.test, at 1x: every frame gets a pose, bound 99 % of the input frames (with 120 frames
  // one may be lost, e.g. while the subscriptions connect). Tracking never waits for a slow mask
  // longer than ~mask_max_wait_s: it goes on with a carried mask, and says so in its status.
  const std::size_t at_least = static_cast<std::size_t>(std::ceil(min_posed_fraction * frames));
  {
    std::lock_guard<std::mutex> lock(rec.mutex);
    const dypho_slam::TrackingStatus& s = rec.last_status;
    std::cout << "graph test (1x): " << rec.statuses << " statuses, " << rec.poses << " poses of " << frames
              << " frames; tracking saw " << s.frames_in << " in, " << s.frames_processed << " processed, "
              << s.frames_dropped << " dropped, " << s.frames_mask_carried << " with a carried mask, "
              << s.frames_without_mask << " without, " << s.frames_caught_up << " caught up; latency p50 "
              << s.latency_p50_ms << " ms, p95 " << s.latency_p95_ms << " ms; mask skipped "
              << rec.last_mask_status.frames_dropped_busy << "\n"
              << "graph test " << input_timing.describe() << "\n";
    EXPECT_EQ(s.frames_processed + s.frames_dropped, s.frames_in) << "every frame is tracked or counted as dropped";
  }
  EXPECT_GE(static_cast<std::size_t>(rec.statuses), at_least);
  EXPECT_GE(static_cast<std::size_t>(rec.poses), at_least);
  EXPECT_GE(rec.masks, frames * 9 / 10);
  EXPECT_EQ(rec.mask_errors, 0);
  // A covariance with nearly every pose (not the first keyframe's, which defines the map), each a
  // valid matrix; its position sigma a few millimetres on this textured synthetic room
  // (dypho_run_dataset on the same frames: timing.csv's position_sigma_mm): bound 5 cm, which a
  // covariance in the wrong units (cm, px) or of the wrong block (rotation) exceeds or undercuts
  // by far, and not below 0.01 mm (the pixel noise model's floor is far above).
  EXPECT_GE(rec.covariances, frames * 8 / 10);
  EXPECT_EQ(rec.bad_covariances, 0);
  {
    std::lock_guard<std::mutex> lock(rec.mutex);
    std::vector<double> sigmas = rec.position_sigmas_m;
    if (!sigmas.empty()) {
      std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
      const double median_m = sigmas[sigmas.size() / 2];
      std::cout << "graph test: " << rec.covariances << " poses with a covariance, median position sigma "
                << median_m * 1e3 << " mm\n";
      EXPECT_LT(median_m, 0.05);
      EXPECT_GT(median_m, 1e-5);
    }
  }
  // Tracking is OK on nearly all frames of this easy sequence (first frame initialises).
  EXPECT_GE(rec.ok_statuses, frames * 8 / 10);
  EXPECT_GE(rec.keyframes, 2);
  EXPECT_GE(rec.clouds, 1);
  EXPECT_GT(rec.cloud_points, 1000u);
  EXPECT_TRUE(tf_buffer.canTransform("map", "dypho_camera", ros::Time(0)));

  // Accuracy: ATE (rigid alignment) against the generator's ground truth.
  const auto gt = dypho::readTumTrajectory(gt_path);
  std::lock_guard<std::mutex> lock(rec.mutex);
  ASSERT_GE(rec.trajectory.size(), 10u);
  const auto ate = dypho::tools::computeAte(rec.trajectory, gt);
  std::cout << "graph test: " << rec.masks << " masks, " << rec.poses << " poses, " << rec.keyframes << " keyframes, "
            << rec.clouds << " clouds (" << rec.cloud_points << " points), ATE RMSE " << ate.rmse_m * 100 << " cm over "
            << ate.num_pairs << " poses\n";
  // Bound 1.5 cm: the same bag run in-process (dypho_run_dataset) gives 0.37 cm and this graph
  // test measured 0.38-0.47 cm. Unlike the in-process run it is not deterministic (which frames
  // the synchroniser drops depends on the load), hence the margin.
  EXPECT_LT(ate.rmse_m, 0.015);

  // The graph uses R_d: the mask nodelet's counter of frames whose background model B_i blended
  // in the depth rendered from the map. The first keyframes' frames have no map to render yet;
  // bound: half of the frames masked.
  const dypho_slam::MaskStatus& mask_status = rec.last_mask_status;
  const bool rendered_depth_on = background_tau > 0.0;
  std::cout << "graph test: mask used R_d on " << mask_status.frames_with_rendered_depth << " of " << mask_status.frames
            << " frames (" << mask_status.rendered_depth_offered << " offered, " << mask_status.rendered_depth_unmatched
            << " unmatched)\n";
  if (rendered_depth_on) {
    EXPECT_GE(mask_status.frames_with_rendered_depth * 2, mask_status.frames);
  }
  if (!rendered_depth_on) {
    EXPECT_EQ(mask_status.frames_with_rendered_depth, 0u) << "R_d is off by default";
  }

  // The same stages in process on the same frames (the sequence folder the bag was written from).
  const InProcessRun in_process = runInProcess(dataset, background_tau);
  std::cout << "in process: R_d on " << in_process.frames_with_rendered_depth << " of " << in_process.frames
            << " frames, " << in_process.keyframe_stamps_s.size() << " keyframes, " << in_process.trajectory.size()
            << " poses\n";
  if (rendered_depth_on) {
    EXPECT_GE(in_process.frames_with_rendered_depth * 2, in_process.frames);
  }
  // Trajectories: the graph's poses against the in-process ones (rigid alignment, matched by
  // stamp). Bound 5 mm: both are about 4 mm from the ground truth, and the graph differs only in
  // timing (which R_d arrives in time for which frame, frames the synchroniser drops).
  const auto agreement = dypho::tools::computeAte(rec.trajectory, in_process.trajectory);
  std::cout << "graph vs in process: trajectory RMSE " << agreement.rmse_m * 100 << " cm over " << agreement.num_pairs
            << " poses; keyframes " << rec.keyframe_stamps_s.size() << " vs " << in_process.keyframe_stamps_s.size()
            << "\n";
  EXPECT_GE(agreement.num_pairs, static_cast<std::size_t>(frames * 8 / 10));
  EXPECT_LT(agreement.rmse_m, 0.005);
  // Keyframes: the same count within 25 %, and at least 60 % of the graph's keyframes at a frame
  // within one frame interval (34 ms at 30 Hz) of an in-process keyframe (a keyframe decision
  // can move by a frame when the inlier count sits at a threshold).
  const double n_graph = static_cast<double>(rec.keyframe_stamps_s.size());
  const double n_local = static_cast<double>(in_process.keyframe_stamps_s.size());
  EXPECT_LE(std::abs(n_graph - n_local), 0.25 * n_local);
  EXPECT_GE(sharedStamps(rec.keyframe_stamps_s, in_process.keyframe_stamps_s, 0.034), 0.6);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_graph");
  return RUN_ALL_TESTS();
}
