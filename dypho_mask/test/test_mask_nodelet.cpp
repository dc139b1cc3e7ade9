/// rostest node for mask_nodelet.test: the mask nodelet alone on the synthetic bag (30 Hz, played
/// at rate 0.5) must publish a mono8 640x480 mask for (nearly) every frame, stamped like the rgb
/// image, and the masks must agree with the bag's ground-truth person masks (mask/<stamp>.png).

#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>

#include <cv_bridge/cv_bridge.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

namespace DYPHO_UNITY_ID {

/// rgb.txt of the TUM layout: stamp [ns] -> file name (e.g. "1600000000.033333.png").
std::map<std::int64_t, std::string> readRgbList(const std::string& path) {
  std::map<std::int64_t, std::string> files;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double stamp_s = 0.0;
    std::string file;
    if (!(fields >> stamp_s >> file)) continue;
    files[std::llround(stamp_s * 1e9)] = file.substr(file.find_last_of('/') + 1);
  }
  return files;
}

/// The entry of `files` within 1 ms of `stamp_ns` (frames are 33 ms apart), or end().
std::map<std::int64_t, std::string>::const_iterator findStamp(const std::map<std::int64_t, std::string>& files,
                                                              std::int64_t stamp_ns) {
  constexpr std::int64_t kToleranceNs = 1'000'000;
  auto it = files.lower_bound(stamp_ns - kToleranceNs);
  if (it != files.end() && std::llabs(it->first - stamp_ns) <= kToleranceNs) return it;
  return files.end();
}

TEST(MaskNodelet, PublishesAMaskPerFrameThatAgreesWithTheGroundTruth) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  int frames = 0;
  std::string masks_dir;
  ASSERT_TRUE(pnh.getParam("frames", frames));
  ASSERT_TRUE(pnh.getParam("masks", masks_dir));
  const auto rgb_files = readRgbList(masks_dir + "/rgb.txt");
  ASSERT_EQ(static_cast<int>(rgb_files.size()), frames) << "rgb.txt in " << masks_dir;

  std::mutex mutex;
  std::map<std::int64_t, cv::Mat> received;  // stamp [ns] -> mask (mono8 only)
  std::atomic<int> messages{0}, wrong_encoding{0}, wrong_size{0}, unknown_stamp{0};
  ros::WallTime last_mask = ros::WallTime::now();
  auto sub = nh.subscribe<sensor_msgs::Image>("/dypho/mask", 200, [&](const sensor_msgs::ImageConstPtr& msg) {
    ++messages;
    std::lock_guard<std::mutex> lock(mutex);
    last_mask = ros::WallTime::now();
    if (msg->encoding != sensor_msgs::image_encodings::MONO8) ++wrong_encoding;
    if (msg->width != 640 || msg->height != 480) ++wrong_size;
    const std::int64_t stamp_ns = static_cast<std::int64_t>(msg->header.stamp.toNSec());
    if (findStamp(rgb_files, stamp_ns) == rgb_files.end()) {
      ++unknown_stamp;
      return;
    }
    if (msg->encoding == sensor_msgs::image_encodings::MONO8) {
      received[stamp_ns] = cv_bridge::toCvCopy(msg)->image;
    }
  });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // The bag lasts frames / 30 Hz / 0.5 = 8 s after a 3 s delay; stop 5 s after the last mask.
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < 45.0) {
    ros::WallDuration(0.5).sleep();
    if (messages >= frames) break;
    std::lock_guard<std::mutex> lock(mutex);
    if (messages > 0 && (ros::WallTime::now() - last_mask).toSec() > 5.0) break;
  }
  spinner.stop();

  std::lock_guard<std::mutex> lock(mutex);
  double iou_sum = 0.0, fraction_sum = 0.0;
  int iou_frames = 0, compared = 0, missing_gt = 0;
  for (const auto& [stamp_ns, mask] : received) {
    const auto it = findStamp(rgb_files, stamp_ns);
    const cv::Mat gt = cv::imread(masks_dir + "/mask/" + it->second, cv::IMREAD_GRAYSCALE);
    if (gt.empty() || gt.size() != mask.size()) {
      ++missing_gt;
      continue;
    }
    ++compared;
    const cv::Mat m = mask > 127, g = gt > 127;
    fraction_sum += cv::countNonZero(m) / static_cast<double>(m.total());
    const double gt_fraction = cv::countNonZero(g) / static_cast<double>(g.total());
    if (gt_fraction < 0.02) continue;  // too few people in view for a meaningful IoU
    const double inter = cv::countNonZero(m & g), uni = cv::countNonZero(m | g);
    iou_sum += inter / uni;
    ++iou_frames;
  }
  const double mean_iou = iou_frames > 0 ? iou_sum / iou_frames : 0.0;
  std::cout << "mask nodelet: " << messages << " masks for " << frames << " frames, " << compared
            << " compared, mean IoU " << mean_iou << " over " << iou_frames
            << " frames with >= 2 % people, mean masked fraction " << (compared > 0 ? fraction_sum / compared : 0.0)
            << "\n";

  // >= 90 % of the frames give a mask: the approximate-time synchroniser may drop the first
  // frames while the subscriptions connect; at half speed the nodelet keeps up on 2 cores.
  EXPECT_GE(messages, frames * 9 / 10);
  EXPECT_EQ(wrong_encoding, 0);
  EXPECT_EQ(wrong_size, 0);
  EXPECT_EQ(unknown_stamp, 0) << "mask stamps must be the rgb image stamps";
  EXPECT_EQ(missing_gt, 0);
  EXPECT_GE(iou_frames, frames / 2);
  // Measured mean IoU 0.890 (two runs, 120/120 masks, Release, 2 shared cores); bound = that
  // minus 0.09 for timing (frames the synchroniser drops under load make the flow span two
  // frames) and flow noise. No tracking runs, so there is no pose prior: the flow removes a
  // global homography instead of the depth-predicted ego-motion the in-process runs use.
  EXPECT_GE(mean_iou, 0.80);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_mask_nodelet");
  return RUN_ALL_TESTS();
}
