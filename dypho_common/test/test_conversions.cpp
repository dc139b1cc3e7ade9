/// toDepthMetres: 32FC1 metres and 16UC1 millimetres to CV_32FC1 metres, every value without a
/// measurement (NaN, inf, negative, 0) stored as 0; other encodings a clear error. No roscore.
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>

#include "dypho_ros/conversions.h"

namespace DYPHO_UNITY_ID {

namespace rc = dypho::ros_conversions;

template <typename T>
sensor_msgs::Image imageOf(const std::vector<T>& values, int width, const std::string& encoding) {
  sensor_msgs::Image image;
  image.width = static_cast<std::uint32_t>(width);
  image.height = static_cast<std::uint32_t>(values.size() / width);
  image.encoding = encoding;
  image.step = static_cast<std::uint32_t>(width * sizeof(T));
  image.data.resize(values.size() * sizeof(T));
  std::memcpy(image.data.data(), values.data(), image.data.size());
  return image;
}

TEST(Conversions, DepthInMetresKeepsMeasurementsAndZeroesTheRest) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<float> metres = {1.5f, nan, inf, -inf, -0.5f, 0.f, 7.25f, 0.001f};
  const cv::Mat d = rc::toDepthMetres(imageOf(metres, 4, sensor_msgs::image_encodings::TYPE_32FC1));
  ASSERT_EQ(d.type(), CV_32FC1);
  ASSERT_EQ(d.size(), cv::Size(4, 2));
  const std::vector<float> want = {1.5f, 0.f, 0.f, 0.f, 0.f, 0.f, 7.25f, 0.001f};
  for (int i = 0; i < 8; ++i) EXPECT_EQ(d.at<float>(i / 4, i % 4), want[static_cast<std::size_t>(i)]) << i;
}

TEST(Conversions, DepthInMillimetresBecomesMetres) {
  const std::vector<std::uint16_t> millimetres = {0, 1000, 65535, 1234, 1, 500};
  const cv::Mat d = rc::toDepthMetres(imageOf(millimetres, 3, sensor_msgs::image_encodings::TYPE_16UC1));
  ASSERT_EQ(d.type(), CV_32FC1);
  ASSERT_EQ(d.size(), cv::Size(3, 2));
  for (int i = 0; i < 6; ++i) {
    EXPECT_FLOAT_EQ(d.at<float>(i / 3, i % 3), millimetres[static_cast<std::size_t>(i)] * 1e-3f) << i;
  }
}

TEST(Conversions, DepthOfAColourEncodingIsAClearError) {
  const std::vector<std::uint8_t> rgb(12, 7);
  try {
    rc::toDepthMetres(imageOf(rgb, 6, sensor_msgs::image_encodings::RGB8));
    FAIL() << "a colour image was taken as depth";
  } catch (const rc::ConversionError& e) {
    EXPECT_NE(std::string(e.what()).find("rgb8"), std::string::npos) << e.what();
  }
}

}  // namespace DYPHO_UNITY_ID
