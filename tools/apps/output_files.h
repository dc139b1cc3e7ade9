#pragma once
/// \file output_files.h
/// dypho_run_dataset's output folders, and --save-masks: each frame's mask as a PNG and the list
/// that --mask gt reads.

#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dypho/common/atomic_file.h"
#include "dypho/common/types.h"

namespace dypho::run_dataset {

/// Creates `path` and its parents; throws std::runtime_error when it is not a folder afterwards.
inline void makeDirs(const std::string& path) {
  std::string partial;
  std::stringstream ss(path);
  std::string part;
  if (!path.empty() && path[0] == '/') partial = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    ::mkdir(partial.c_str(), 0755);
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    throw std::runtime_error("cannot create output folder '" + path + "'");
  }
}

/// --save-masks: OUT/mask/<stamp>.png (8-bit, 255 = dynamic; an empty mask is written all static)
/// and OUT/mask.txt ("stamp mask/<stamp>.png"), the layout dypho_synth writes for --mask gt.
class MaskWriter {
 public:
  explicit MaskWriter(std::string out_dir) : out_dir_(std::move(out_dir)) {}
  void write(Timestamp stamp_ns, const cv::Mat& mask, const cv::Size& size) {
    if (lines_.empty()) makeDirs(out_dir_ + "/mask");
    char stamp[64];
    std::snprintf(stamp, sizeof(stamp), "%lld.%06lld", static_cast<long long>(stamp_ns / 1000000000),
                  static_cast<long long>((stamp_ns % 1000000000) / 1000));
    const cv::Mat img = mask.empty() ? cv::Mat::zeros(size, CV_8UC1) : mask;
    std::vector<std::uint8_t> png;
    if (!cv::imencode(".png", img, png)) throw std::runtime_error(std::string("PNG encoding failed for mask ") + stamp);
    writeFileAtomically(
        out_dir_ + "/mask/" + stamp + ".png",
        [&](std::ostream& os) {
          os.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
        },
        true);
    lines_ += std::string(stamp) + " mask/" + stamp + ".png\n";
  }
  /// Writes mask.txt (after all images, so it never names a missing one).
  void finish() const {
    if (lines_.empty()) return;
    writeFileAtomically(out_dir_ + "/mask.txt", [&](std::ostream& os) { os << "# timestamp filename\n" << lines_; });
  }

 private:
  std::string out_dir_;
  std::string lines_;
};

}  // namespace dypho::run_dataset
