// Unit tests of dypho_bag: round trip through a bag, accepted encodings and clear errors.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <unistd.h>

#include "dypho/tools/bag_io.h"

namespace fs = std::filesystem;
using dypho::RgbdFrame;
using dypho::tools::BagLayout;
using dypho::tools::BagRgbdReader;
using dypho::tools::BagRgbdWriter;
using dypho::tools::BagTopics;

namespace DYPHO_UNITY_ID {

std::string tempBag(const std::string& name) {
  return (fs::temp_directory_path() / ("dypho_" + name + "_" + std::to_string(::getpid()) + ".bag")).string();
}

dypho::CameraIntrinsics testCamera() {
  dypho::CameraIntrinsics c;
  c.fx = 517.3;
  c.fy = 516.5;
  c.cx = 318.6;
  c.cy = 255.3;
  c.width = 64;
  c.height = 48;
  c.distortion = {{0.26, -0.95, -0.005, 0.003, 1.16}};
  return c;
}

RgbdFrame randomFrame(int i, cv::RNG& rng) {
  RgbdFrame f;
  f.camera = testCamera();
  f.stamp_ns = 1305031229528748000LL + i * 33333000LL;
  f.bgr.create(48, 64, CV_8UC3);
  rng.fill(f.bgr, cv::RNG::UNIFORM, 0, 256);
  f.depth_m.create(48, 64, CV_32FC1);
  rng.fill(f.depth_m, cv::RNG::UNIFORM, 0.5, 5.0);
  f.depth_m.forEach<float>([](float& z, const int*) { z = std::round(z * 5000.f) / 5000.f; });  // TUM steps
  f.depth_m(cv::Rect(0, 0, 10, 5)).setTo(0.f);                                                  // no measurement
  return f;
}

sensor_msgs::Image rawImage(int w, int h, const std::string& enc, int bytes_per_px, double stamp_s) {
  sensor_msgs::Image m;
  m.header.stamp = ros::Time(stamp_s);
  m.width = w;
  m.height = h;
  m.encoding = enc;
  m.step = w * bytes_per_px;
  m.data.assign(static_cast<std::size_t>(m.step) * h, 7);
  return m;
}

/// Writes one frame with hand-made encodings through rosbag directly.
void writeRawBag(const std::string& path, const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth,
                 bool with_info = true) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  const BagTopics t;
  bag.write(t.rgb, rgb.header.stamp, rgb);
  bag.write(t.depth, depth.header.stamp, depth);
  if (with_info) {
    sensor_msgs::CameraInfo info;
    info.header = rgb.header;
    info.width = rgb.width;
    info.height = rgb.height;
    info.K = {500, 0, 10, 0, 500, 8, 0, 0, 1};
    info.distortion_model = "plumb_bob";
    info.D = {0, 0, 0, 0, 0};
    bag.write(t.camera_info, rgb.header.stamp, info);
  }
  bag.close();
}

template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(BagIo, RoundTripKeepsFramesStampsAndCamera) {
  const std::string path = tempBag("roundtrip");
  cv::RNG rng(42);
  std::vector<RgbdFrame> frames;
  {
    BagRgbdWriter w(path);
    for (int i = 0; i < 5; ++i) {
      frames.push_back(randomFrame(i, rng));
      w.write(frames.back());
    }
    w.close();
    EXPECT_EQ(w.framesWritten(), 5u);
    EXPECT_THROW(w.write(frames[0]), std::runtime_error);
  }
  const BagRgbdReader r(path);
  ASSERT_EQ(r.size(), frames.size());
  const auto cam = r.camera();
  EXPECT_DOUBLE_EQ(cam.fx, testCamera().fx);
  EXPECT_DOUBLE_EQ(cam.cy, testCamera().cy);
  EXPECT_EQ(cam.width, 64);
  EXPECT_DOUBLE_EQ(cam.distortion[4], testCamera().distortion[4]);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const RgbdFrame f = r.load(i);
    EXPECT_EQ(f.stamp_ns, frames[i].stamp_ns);
    EXPECT_EQ(cv::norm(f.bgr, frames[i].bgr, cv::NORM_INF), 0.0);  // rgb8 is lossless
    // 32FC1 stores the float exactly; "within quantisation" = below half a 1/5000 m step.
    EXPECT_LT(cv::norm(f.depth_m, frames[i].depth_m, cv::NORM_INF), 1e-4);
    EXPECT_EQ(cv::countNonZero(f.depth_m == 0.f), 50) << "0 -> NaN in the bag -> 0 again";
  }
  EXPECT_THROW(r.load(5), std::out_of_range);
  fs::remove(path);
}

TEST(BagIo, MissingTopicListsTheTopicsInTheBag) {
  const std::string path = tempBag("missing");
  cv::RNG rng(1);
  BagTopics other;
  other.rgb = "/kinect/color";
  {
    BagRgbdWriter w(path, other);
    w.write(randomFrame(0, rng));
  }
  const std::string msg = errorOf([&] { BagRgbdReader r(path); });
  EXPECT_NE(msg.find("/camera/rgb/image_color"), std::string::npos) << msg;
  EXPECT_NE(msg.find("/kinect/color"), std::string::npos) << msg;
  EXPECT_NO_THROW(BagRgbdReader(path, other));
  EXPECT_NE(errorOf([] { BagRgbdReader r("/nonexistent/x.bag"); }).find("cannot open bag"), std::string::npos);
  EXPECT_NE(errorOf([] { BagRgbdWriter w("/nonexistent/dir/x.bag"); }).find("cannot create bag"), std::string::npos);
  fs::remove(path);
}

TEST(BagIo, WrongEncodingsAreNamed) {
  const std::string path = tempBag("encoding");
  writeRawBag(path, rawImage(20, 16, "bgr16", 6, 10.0), rawImage(20, 16, "32FC1", 4, 10.0));
  std::string msg = errorOf([&] { BagRgbdReader(path).load(0); });
  EXPECT_NE(msg.find("bgr16"), std::string::npos) << msg;
  EXPECT_NE(msg.find("/camera/rgb/image_color"), std::string::npos) << msg;
  EXPECT_NE(msg.find("rgb8, bgr8, rgba8, bgra8, mono8"), std::string::npos) << msg;

  writeRawBag(path, rawImage(20, 16, "rgb8", 3, 10.0), rawImage(20, 16, "16UC3", 6, 10.0));
  msg = errorOf([&] { BagRgbdReader(path).load(0); });
  EXPECT_NE(msg.find("16UC3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("/camera/depth/image"), std::string::npos) << msg;
  EXPECT_NE(msg.find("32FC1"), std::string::npos) << msg;
  fs::remove(path);
}

TEST(BagIo, AcceptsMono8Bgr8AndOpenNiMillimetres) {
  const std::string path = tempBag("accepted");
  auto mono = rawImage(20, 16, "mono8", 1, 10.0);
  mono.data[0] = 200;
  auto mm = rawImage(20, 16, "16UC1", 2, 10.01);  // 10 ms later: associates within 20 ms
  const std::uint16_t v = 1234;
  std::memcpy(mm.data.data(), &v, 2);
  writeRawBag(path, mono, mm);
  {
    const RgbdFrame f = BagRgbdReader(path).load(0);
    ASSERT_EQ(f.bgr.type(), CV_8UC3);
    EXPECT_EQ(f.bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(200, 200, 200));
    EXPECT_FLOAT_EQ(f.depth_m.at<float>(0, 0), 1.234f);
    EXPECT_DOUBLE_EQ(f.camera.fx, 500.0);
  }
  auto bgr = rawImage(20, 16, "bgr8", 3, 10.0);
  bgr.data[0] = 10;
  bgr.data[1] = 20;
  bgr.data[2] = 30;
  auto depth = rawImage(20, 16, "32FC1", 4, 10.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(depth.data.data(), &nan, 4);
  writeRawBag(path, bgr, depth, /*with_info=*/false);
  BagRgbdReader r(path);
  const std::string msg = errorOf([&] { r.load(0); });
  EXPECT_NE(msg.find("--camera"), std::string::npos) << "no camera_info must ask for --camera: " << msg;
  dypho::CameraIntrinsics c = testCamera();
  c.width = 20;
  c.height = 16;
  r.setCamera(c);
  const RgbdFrame f = r.load(0);
  EXPECT_EQ(f.bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(f.depth_m.at<float>(0, 0), 0.f) << "NaN depth must become 0";
  fs::remove(path);
}

TEST(BagIo, DepthFartherThanMaxDtDoesNotAssociate) {
  const std::string path = tempBag("assoc");
  writeRawBag(path, rawImage(20, 16, "rgb8", 3, 10.0), rawImage(20, 16, "32FC1", 4, 10.05));
  const std::string msg = errorOf([&] { BagRgbdReader r(path); });
  EXPECT_NE(msg.find("within"), std::string::npos) << msg;
  EXPECT_EQ(BagRgbdReader(path, BagTopics{}, 0.1).size(), 1u);
  fs::remove(path);
}

/// The one message of `topic` in the bag at `path` (fails the test when there is not exactly one).
template <typename M>
M onlyMessage(const std::string& path, const std::string& topic) {
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  std::vector<M> found;
  for (const rosbag::MessageInstance& m : view) {
    if (auto p = m.instantiate<M>()) found.push_back(*p);
  }
  EXPECT_EQ(found.size(), 1u) << topic;
  return found.empty() ? M() : found.front();
}

TEST(BagLayout, NamesParseAndUnknownNamesAreRefused) {
  for (BagLayout l : {BagLayout::kTum, BagLayout::kRealSense, BagLayout::kOpenNi}) {
    EXPECT_EQ(dypho::tools::parseBagLayout(dypho::tools::bagLayoutName(l)), l);
  }
  try {
    dypho::tools::parseBagLayout("kinect");
    FAIL() << "an unknown layout must throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tum, realsense, openni"), std::string::npos) << e.what();
  }
  // tum = the defaults (today's bags).
  const BagTopics tum = dypho::tools::bagTopicsFor(BagLayout::kTum);
  EXPECT_EQ(tum.rgb, BagTopics{}.rgb);
  EXPECT_EQ(tum.depth_encoding, "32FC1");
  // An encoding the writer cannot produce is refused before the bag is created.
  BagTopics bad;
  bad.depth_encoding = "16UC3";
  const std::string path = tempBag("badenc");
  try {
    BagRgbdWriter w(path, bad);
    FAIL() << "depth encoding 16UC3 must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("16UC3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("32FC1 (metres), 16UC1 (millimetres)"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path));
}

// RealSense (align_depth) names and encodings; depth in millimetres rounded to nearest, every kind
// of "no measurement" and depth beyond 16 bits written as 0; read back by BagRgbdReader.
TEST(BagLayout, RealSenseWritesMillimetresWithZeroForNoDepth) {
  const std::string path = tempBag("realsense");
  const BagTopics topics = dypho::tools::bagTopicsFor(BagLayout::kRealSense);
  cv::RNG rng(3);
  RgbdFrame f = randomFrame(0, rng);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  // {metres written, millimetres expected}
  const std::vector<std::pair<float, std::uint16_t>> cases = {
      {1.2344f, 1234}, {1.2346f, 1235}, {0.0006f, 1},     {0.0004f, 0}, {0.f, 0},   {nan, 0},
      {-1.f, 0},       {inf, 0},        {65.535f, 65535}, {65.6f, 0},   {3.f, 3000}};
  for (std::size_t i = 0; i < cases.size(); ++i) f.depth_m.at<float>(47, static_cast<int>(i)) = cases[i].first;
  {
    BagRgbdWriter w(path, topics);
    w.write(f);
    w.close();
  }
  const auto rgb = onlyMessage<sensor_msgs::Image>(path, "/camera/color/image_raw");
  const auto depth = onlyMessage<sensor_msgs::Image>(path, "/camera/aligned_depth_to_color/image_raw");
  const auto info = onlyMessage<sensor_msgs::CameraInfo>(path, "/camera/color/camera_info");
  EXPECT_EQ(rgb.encoding, "rgb8");
  EXPECT_EQ(depth.encoding, "16UC1");
  EXPECT_EQ(depth.step, 64u * 2u);
  for (const std::string& frame : {rgb.header.frame_id, depth.header.frame_id, info.header.frame_id}) {
    EXPECT_EQ(frame, "camera_color_optical_frame");
  }
  EXPECT_EQ(depth.header.stamp, rgb.header.stamp);
  ASSERT_EQ(depth.data.size(), 64u * 48u * 2u);
  auto mmAt = [&](int row, int col) {
    std::uint16_t v;
    std::memcpy(&v, depth.data.data() + static_cast<std::size_t>(row) * depth.step + 2 * col, 2);
    return v;
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    EXPECT_EQ(mmAt(47, static_cast<int>(i)), cases[i].second) << "case " << i << ": " << cases[i].first << " m";
  }
  EXPECT_EQ(mmAt(0, 0), 0) << "the 0 m block of randomFrame";
  // rgb8: the first pixel's channels swapped from BGR.
  const cv::Vec3b bgr = f.bgr.at<cv::Vec3b>(0, 0);
  EXPECT_EQ(rgb.data[0], bgr[2]);
  EXPECT_EQ(rgb.data[2], bgr[0]);

  // Read back with the layout's topics: within half a millimetre, 0 where there is no depth.
  const BagRgbdReader r(path, topics);
  ASSERT_EQ(r.size(), 1u);
  const RgbdFrame back = r.load(0);
  EXPECT_EQ(back.stamp_ns, f.stamp_ns);
  EXPECT_EQ(cv::norm(back.bgr, f.bgr, cv::NORM_INF), 0.0);
  cv::Mat valid = (f.depth_m > 0.f) & (f.depth_m < 65.5f);  // NaN compares false
  valid.row(47).setTo(0);                                   // the edge cases, checked above
  cv::Mat diff;
  cv::absdiff(back.depth_m, f.depth_m, diff);
  double max_diff = 0;
  cv::minMaxLoc(diff, nullptr, &max_diff, nullptr, nullptr, valid);
  EXPECT_LE(max_diff, 0.0005 + 1e-6) << "mm rounding is within half a millimetre";
  EXPECT_FLOAT_EQ(back.depth_m.at<float>(47, 1), 1.235f);
  EXPECT_EQ(back.depth_m.at<float>(47, 5), 0.f) << "NaN -> 0 mm -> 0 m (no depth)";
  EXPECT_DOUBLE_EQ(r.camera().fx, testCamera().fx);
  fs::remove(path);
}

TEST(BagLayout, OpenNiNamesAndBgr8Colour) {
  const std::string path = tempBag("openni");
  BagTopics topics = dypho::tools::bagTopicsFor(BagLayout::kOpenNi);
  EXPECT_EQ(topics.colour_encoding, "rgb8") << "openni2_camera publishes rgb8";
  topics.colour_encoding = "bgr8";  // what image_proc gives when asked for bgr8: also accepted
  cv::RNG rng(4);
  const RgbdFrame f = randomFrame(0, rng);
  {
    BagRgbdWriter w(path, topics);
    w.write(f);
  }
  const auto rgb = onlyMessage<sensor_msgs::Image>(path, "/camera/rgb/image_rect_color");
  const auto depth = onlyMessage<sensor_msgs::Image>(path, "/camera/depth_registered/image_raw");
  const auto info = onlyMessage<sensor_msgs::CameraInfo>(path, "/camera/rgb/camera_info");
  EXPECT_EQ(rgb.encoding, "bgr8");
  EXPECT_EQ(depth.encoding, "16UC1");
  EXPECT_EQ(info.header.frame_id, "camera_rgb_optical_frame");
  EXPECT_EQ(rgb.data[0], f.bgr.at<cv::Vec3b>(0, 0)[0]);
  const BagRgbdReader r(path, topics);
  EXPECT_EQ(cv::norm(r.load(0).bgr, f.bgr, cv::NORM_INF), 0.0);
  fs::remove(path);
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
