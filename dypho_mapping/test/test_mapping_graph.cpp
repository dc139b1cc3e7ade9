/// Mapping graph test (rostest, test/mapping_graph.test): the Gaussian mapping nodelet in the full
/// pipeline on the synthetic bag publishes rendered colour/depth at the tracked pose, the depth
/// predicted for the next frame, the Gaussian-centre cloud and the keyframe cloud.
#include <atomic>
#include <cmath>

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

namespace DYPHO_UNITY_ID {

/// Share of pixels of a 32FC1 image with a finite depth in (0.1, 20) m; -1 when not 32FC1.
double validDepthShare(const sensor_msgs::Image& m) {
  if (m.encoding != "32FC1" || m.width == 0 || m.step < m.width * 4) return -1.0;
  std::size_t valid = 0;
  for (std::uint32_t y = 0; y < m.height; ++y) {
    const float* row = reinterpret_cast<const float*>(&m.data[y * m.step]);
    for (std::uint32_t x = 0; x < m.width; ++x) valid += std::isfinite(row[x]) && row[x] > 0.1f && row[x] < 20.f;
  }
  return static_cast<double>(valid) / (static_cast<double>(m.width) * m.height);
}

TEST(MappingGraphTest, RenderedImagesAndCloudsArePublished) {
  ros::NodeHandle nh;
  std::atomic<int> colors{0}, depths{0}, predicted{0}, gaussian_clouds{0}, map_clouds{0}, bad{0};
  std::atomic<double> best_depth_share{0.0}, best_predicted_share{0.0};
  std::atomic<std::size_t> gaussians{0};
  auto color_sub =
      nh.subscribe<sensor_msgs::Image>("/dypho/rendered/color", 5, [&](const sensor_msgs::ImageConstPtr& m) {
        if (m->encoding != "bgr8" || m->width != 640 || m->height != 480) ++bad;
        ++colors;
      });
  auto depth_sub =
      nh.subscribe<sensor_msgs::Image>("/dypho/rendered/depth", 5, [&](const sensor_msgs::ImageConstPtr& m) {
        const double s = validDepthShare(*m);
        if (s < 0) ++bad;
        best_depth_share = std::max(best_depth_share.load(), s);
        ++depths;
      });
  ros::Time last_pose_stamp;
  auto pred_sub =
      nh.subscribe<sensor_msgs::Image>("/dypho/rendered/depth_predicted", 5, [&](const sensor_msgs::ImageConstPtr& m) {
        const double s = validDepthShare(*m);
        if (s < 0 || m->header.stamp.isZero()) ++bad;
        best_predicted_share = std::max(best_predicted_share.load(), s);
        ++predicted;
      });
  auto gc_sub = nh.subscribe<sensor_msgs::PointCloud2>("/dypho/gaussian_cloud", 2,
                                                       [&](const sensor_msgs::PointCloud2ConstPtr& c) {
                                                         if (c->header.frame_id != "map") ++bad;
                                                         gaussians = static_cast<std::size_t>(c->width) * c->height;
                                                         ++gaussian_clouds;
                                                       });
  auto mc_sub = nh.subscribe<sensor_msgs::PointCloud2>("/dypho/map_cloud", 2,
                                                       [&](const sensor_msgs::PointCloud2ConstPtr&) { ++map_clouds; });

  // Wait (wall time) until every output has arrived a few times, at most 120 s.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(120.0);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  while (
      ros::ok() && ros::WallTime::now() < deadline &&
      (colors < 3 || depths < 3 || predicted < 5 || gaussian_clouds < 2 || map_clouds < 1 || best_depth_share < 0.5)) {
    ros::WallDuration(0.2).sleep();
  }
  EXPECT_GE(colors.load(), 3);
  EXPECT_GE(depths.load(), 3);
  EXPECT_GE(predicted.load(), 5);
  EXPECT_GE(gaussian_clouds.load(), 2);
  EXPECT_GE(map_clouds.load(), 1);
  EXPECT_EQ(bad.load(), 0);
  EXPECT_GT(gaussians.load(), 1000u);  // seeded from several keyframes
  // The room fills the view: most rendered pixels carry a depth (>= 50 %, loose because the first
  // renders come right after the first keyframe, before the map covers the view).
  EXPECT_GE(best_depth_share.load(), 0.5);
  EXPECT_GE(best_predicted_share.load(), 0.5);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_mapping_graph");
  return RUN_ALL_TESTS();
}
