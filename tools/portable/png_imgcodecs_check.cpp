/// Checks tools/portable/png_imgcodecs.cpp against OpenCV's own codec (scripts/gpu_system.sh
/// prepare builds this twice, once with each, and compares what they print):
///   png_imgcodecs_check write DIR   writes test images (imwrite and imencode) into DIR
///   png_imgcodecs_check read DIR    prints type, size and a pixel hash of each image in DIR for
///                                   each imread flag the project uses, and for imdecode
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace {

std::uint64_t pixelHash(const cv::Mat& img) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a over the rows' bytes
  for (int y = 0; y < img.rows; ++y) {
    const unsigned char* p = img.ptr<unsigned char>(y);
    for (std::size_t i = 0; i < img.cols * img.elemSize(); ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  return h;
}

/// Deterministic content that uses every bit of each sample.
cv::Mat pattern(int rows, int cols, int type) {
  cv::Mat img(rows, cols, type);
  std::uint32_t s = 12345u + static_cast<std::uint32_t>(type);
  for (int y = 0; y < rows; ++y) {
    unsigned char* p = img.ptr<unsigned char>(y);
    for (std::size_t i = 0; i < cols * img.elemSize(); ++i) {
      s = s * 1664525u + 1013904223u;
      p[i] = static_cast<unsigned char>((s >> 24) ^ (y * 7 + i));
    }
  }
  return img;
}

int write(const std::string& dir) {
  std::filesystem::create_directories(dir);
  const std::vector<std::pair<std::string, int>> types = {
      {"u8c1", CV_8UC1}, {"u8c3", CV_8UC3}, {"u8c4", CV_8UC4}, {"u16c1", CV_16UC1}, {"u16c3", CV_16UC3}};
  for (const auto& [name, type] : types) {
    for (const cv::Size size : {cv::Size(37, 23), cv::Size(640, 480)}) {
      const cv::Mat img = pattern(size.height, size.width, type);
      const std::string stem = dir + "/" + name + "_" + std::to_string(size.width);
      if (!cv::imwrite(stem + "_imwrite.png", img)) return 1;
      if (!cv::imwrite(stem + "_level9.png", img, {cv::IMWRITE_PNG_COMPRESSION, 9})) return 1;
      std::vector<uchar> buf;
      if (!cv::imencode(".png", img, buf)) return 1;
      std::ofstream(stem + "_imencode.png", std::ios::binary)
          .write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
    }
  }
  return 0;
}

int read(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  const std::vector<std::pair<std::string, int>> flags = {{"unchanged", cv::IMREAD_UNCHANGED},
                                                          {"color", cv::IMREAD_COLOR},
                                                          {"grayscale", cv::IMREAD_GRAYSCALE},
                                                          {"anydepth", cv::IMREAD_ANYDEPTH}};
  for (const std::string& f : files) {
    for (const auto& [flag_name, flag] : flags) {
      const cv::Mat img = cv::imread(dir + "/" + f, flag);
      std::printf("%s %s type %d %dx%d %016llx\n", f.c_str(), flag_name.c_str(), img.type(), img.cols, img.rows,
                  static_cast<unsigned long long>(pixelHash(img)));
    }
    std::ifstream in(dir + "/" + f, std::ios::binary);
    const std::vector<uchar> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const cv::Mat img = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    std::printf("%s imdecode type %d %dx%d %016llx\n", f.c_str(), img.type(), img.cols, img.rows,
                static_cast<unsigned long long>(pixelHash(img)));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc == 3 ? argv[1] : "";
  if (mode == "write") return write(argv[2]);
  if (mode == "read") return read(argv[2]);
  std::fprintf(stderr, "usage: png_imgcodecs_check write|read DIR\n");
  return 2;
}
