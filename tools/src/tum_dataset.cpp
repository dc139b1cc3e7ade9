#include "dypho/tools/tum_dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include <opencv2/imgcodecs.hpp>

namespace fs = std::filesystem;

namespace dypho::tools {
namespace {

std::string absolutePath(const fs::path& dir, const std::string& rel) {
  const fs::path p(rel);
  return (p.is_absolute() ? p : fs::absolute(dir / p)).lexically_normal().string();
}

std::string describeMat(const cv::Mat& m) {
  static const char* kDepths[] = {"8U", "8S", "16U", "16S", "32S", "32F", "64F", "16F"};
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " + kDepths[m.depth()] + "C" +
         std::to_string(m.channels());
}

}  // namespace

bool parseSecondsToNs(const std::string& text, Timestamp* stamp_ns) {
  std::size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '-' || text[i] == '+')) negative = text[i++] == '-';
  Timestamp whole = 0;
  Timestamp frac = 0;
  int int_digits = 0;
  int frac_digits = 0;
  for (; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i, ++int_digits) {
    if (int_digits >= 10) return false;  // >= 1e10 s cannot be int64 nanoseconds
    whole = whole * 10 + (text[i] - '0');
  }
  if (i < text.size() && text[i] == '.') {
    for (++i; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i) {
      if (frac_digits < 9) {
        frac = frac * 10 + (text[i] - '0');
        ++frac_digits;
      } else if (frac_digits == 9) {  // round on the 10th decimal, ignore the rest
        if (text[i] >= '5') ++frac;
        ++frac_digits;
      }
    }
  }
  if (i != text.size() || (int_digits == 0 && frac_digits == 0)) return false;
  for (int d = std::min(frac_digits, 9); d < 9; ++d) frac *= 10;
  // int64 nanoseconds reach 9223372036.854775807 s (year 2262); later stamps do not fit.
  constexpr Timestamp kMaxWholeSeconds = 9223372035;
  if (whole > kMaxWholeSeconds) return false;
  const Timestamp ns = whole * 1000000000LL + frac;
  *stamp_ns = negative ? -ns : ns;
  return true;
}

std::vector<StampedFile> readStampedFileList(const std::string& list_path, std::vector<std::string>* skipped) {
  std::ifstream in(list_path);
  if (!in) {
    throw DatasetError("cannot open '" + list_path +
                       "': a TUM-layout folder needs rgb.txt and depth.txt (\"timestamp filename\" "
                       "lines); check the dataset path");
  }
  std::vector<StampedFile> files;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    std::string stamp_text;
    std::string path;
    ss >> stamp_text;
    std::getline(ss >> std::ws, path);
    while (!path.empty() && std::isspace(static_cast<unsigned char>(path.back()))) path.pop_back();
    StampedFile f;
    if (path.empty() || !parseSecondsToNs(stamp_text, &f.stamp_ns)) {
      const std::string message = list_path + ":" + std::to_string(line_no) +
                                  ": expected \"timestamp filename\" (e.g. \"1305031229.528748 "
                                  "rgb/1305031229.528748.png\"), got '" +
                                  line + "'";
      if (skipped == nullptr) throw DatasetError(message);
      skipped->push_back(message + " (line skipped)");
      continue;
    }
    f.stamp_s = std::stod(stamp_text);
    f.path = path;
    files.push_back(f);
  }
  return files;
}

std::vector<std::pair<std::size_t, std::size_t>> associateStamps(const std::vector<double>& first,
                                                                 const std::vector<double>& second, double max_dt_s) {
  // Candidates within the window, found by binary search over `second` sorted by stamp.
  std::vector<std::size_t> order(second.size());
  for (std::size_t j = 0; j < order.size(); ++j) order[j] = j;
  std::sort(order.begin(), order.end(), [&second](std::size_t a, std::size_t b) { return second[a] < second[b]; });
  std::vector<double> sorted(second.size());
  for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = second[order[k]];

  struct Candidate {
    double diff;
    std::size_t i;
    std::size_t j;
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < first.size(); ++i) {
    auto it = std::lower_bound(sorted.begin(), sorted.end(), first[i] - max_dt_s);
    for (; it != sorted.end() && *it <= first[i] + max_dt_s; ++it) {
      const double diff = std::abs(first[i] - *it);
      if (diff < max_dt_s) candidates.push_back({diff, i, order[it - sorted.begin()]});
    }
  }
  // associate.py sorts (diff, a, b) tuples: ties broken by the smaller stamps.
  std::sort(candidates.begin(), candidates.end(), [&](const Candidate& a, const Candidate& b) {
    return std::make_tuple(a.diff, first[a.i], second[a.j]) < std::make_tuple(b.diff, first[b.i], second[b.j]);
  });
  std::vector<bool> used_first(first.size(), false);
  std::vector<bool> used_second(second.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> matches;
  for (const auto& c : candidates) {
    if (used_first[c.i] || used_second[c.j]) continue;
    used_first[c.i] = used_second[c.j] = true;
    matches.emplace_back(c.i, c.j);
  }
  std::sort(matches.begin(), matches.end(),
            [&first](const auto& a, const auto& b) { return first[a.first] < first[b.first]; });
  return matches;
}

TumDataset TumDataset::open(const std::string& dir, const CameraConfig& camera, double max_dt_s) {
  if (!fs::is_directory(dir)) {
    throw DatasetError("dataset folder '" + dir + "' does not exist (check the path)");
  }
  if (!camera.camera.valid() || !(camera.depth_scale > 0.0)) {
    throw DatasetError("camera '" + camera.name + "' for dataset '" + dir +
                       "' is invalid (load it with loadCameraConfig)");
  }
  if (!(max_dt_s > 0.0)) {
    throw DatasetError("association window max_dt_s must be > 0 (TUM uses 0.02 s)");
  }
  const fs::path root(dir);
  std::vector<std::string> skipped;
  const auto rgb = readStampedFileList((root / "rgb.txt").string(), &skipped);
  const auto depth = readStampedFileList((root / "depth.txt").string(), &skipped);
  if (rgb.empty()) throw DatasetError((root / "rgb.txt").string() + " lists no images");
  if (depth.empty()) throw DatasetError((root / "depth.txt").string() + " lists no images");

  std::vector<double> rgb_stamps, depth_stamps;
  for (const auto& f : rgb) rgb_stamps.push_back(f.stamp_s);
  for (const auto& f : depth) depth_stamps.push_back(f.stamp_s);

  TumDataset ds;
  ds.dir_ = dir;
  ds.camera_ = camera;
  ds.num_rgb_lines_ = rgb.size();
  ds.skipped_lines_ = std::move(skipped);
  for (const auto& [i, j] : associateStamps(rgb_stamps, depth_stamps, max_dt_s)) {
    DatasetEntry e;
    e.stamp_s = rgb[i].stamp_s;
    e.stamp_ns = rgb[i].stamp_ns;
    e.depth_stamp_s = depth[j].stamp_s;
    e.rgb_path = absolutePath(root, rgb[i].path);
    e.depth_path = absolutePath(root, depth[j].path);
    ds.entries_.push_back(std::move(e));
  }
  if (ds.entries_.empty()) {
    throw DatasetError("no rgb.txt stamp in '" + dir + "' has a depth.txt stamp within " + std::to_string(max_dt_s) +
                       " s (wrong files, or raise max_dt_s)");
  }

  const fs::path gt = root / "groundtruth.txt";
  if (fs::exists(gt)) {
    try {
      ds.groundtruth_ = readTumTrajectory(gt.string());
    } catch (const std::runtime_error& e) {
      throw DatasetError(std::string("malformed ground truth: ") + e.what());
    }
  }
  return ds;
}

const DatasetEntry& TumDataset::entry(std::size_t i) const {
  if (i >= entries_.size()) {
    throw std::out_of_range("TumDataset::entry(" + std::to_string(i) + "): only " + std::to_string(entries_.size()) +
                            " entries");
  }
  return entries_[i];
}

RgbdFrame TumDataset::load(std::size_t i) const {
  const DatasetEntry& e = entry(i);
  const int w = camera_.camera.width;
  const int h = camera_.camera.height;
  const std::string expected = std::to_string(w) + "x" + std::to_string(h);

  RgbdFrame frame;
  frame.stamp_ns = e.stamp_ns;
  frame.camera = camera_.camera;
  frame.bgr = cv::imread(e.rgb_path, cv::IMREAD_COLOR);
  if (frame.bgr.empty()) {
    throw DatasetError("cannot read colour image '" + e.rgb_path +
                       "' (missing or not an image; check that the file listed in rgb.txt exists)");
  }
  if (frame.bgr.cols != w || frame.bgr.rows != h) {
    throw DatasetError("colour image '" + e.rgb_path + "' is " + describeMat(frame.bgr) + ", camera '" + camera_.name +
                       "' expects " + expected + " (use the camera config that matches this dataset)");
  }
  const cv::Mat raw = cv::imread(e.depth_path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) {
    throw DatasetError("cannot read depth image '" + e.depth_path +
                       "' (missing or not an image; check that the file listed in depth.txt exists)");
  }
  if (raw.type() != CV_16UC1) {
    throw DatasetError("depth image '" + e.depth_path + "' is " + describeMat(raw) +
                       ", expected a 16-bit single-channel PNG (16UC1, raw / depth_scale = metres); "
                       "do not convert depth to 8 bit");
  }
  if (raw.cols != w || raw.rows != h) {
    throw DatasetError("depth image '" + e.depth_path + "' is " + describeMat(raw) + ", camera '" + camera_.name +
                       "' expects " + expected + " (depth must be registered to the colour image)");
  }
  raw.convertTo(frame.depth_m, CV_32FC1, 1.0 / camera_.depth_scale);  // 0 stays 0
  return frame;
}

}  // namespace dypho::tools
