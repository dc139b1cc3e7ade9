// Unit tests of dypho_bag: round trip through a bag, accepted encodings and clear errors.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <unistd.h>

#include "dypho/tools/bag_io.h"

namespace fs = std::filesystem;
using dypho::RgbdFrame;
using dypho::tools::BagRgbdReader;
using dypho::tools::BagRgbdWriter;
using dypho::tools::BagTopics;

namespace {

std::string tempBag(const std::string& name) {
  return (fs::temp_directory_path() / ("dypho_" + name + "_" + std::to_string(::getpid()) + ".bag")).string();
}

dypho::CameraIntrinsics testCamera() {
  dypho::CameraIntrinsics c;
  c.fx = 517.3; c.fy = 516.5; c.cx = 318.6; c.cy = 255.3;
  c.width = 64; c.height = 48;
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
  f.depth_m(cv::Rect(0, 0, 10, 5)).setTo(0.f);  // no measurement
  return f;
}

sensor_msgs::Image rawImage(int w, int h, const std::string& enc, int bytes_per_px, double stamp_s) {
  sensor_msgs::Image m;
  m.header.stamp = ros::Time(stamp_s);
  m.width = w; m.height = h; m.encoding = enc;
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
    info.width = rgb.width; info.height = rgb.height;
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

}  // namespace

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
  bgr.data[0] = 10; bgr.data[1] = 20; bgr.data[2] = 30;
  auto depth = rawImage(20, 16, "32FC1", 4, 10.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(depth.data.data(), &nan, 4);
  writeRawBag(path, bgr, depth, /*with_info=*/false);
  BagRgbdReader r(path);
  const std::string msg = errorOf([&] { r.load(0); });
  EXPECT_NE(msg.find("--camera"), std::string::npos) << "no camera_info must ask for --camera: " << msg;
  dypho::CameraIntrinsics c = testCamera();
  c.width = 20; c.height = 16;
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

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
