#pragma once
/// \file tum_dataset.h
/// Reader for TUM-layout RGB-D folders (TUM RGB-D benchmark and the Bonn RGB-D Dynamic Dataset):
/// rgb.txt, depth.txt, optional groundtruth.txt, rgb/*.png (8-bit colour), depth/*.png (16-bit).

#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dypho/common/types.h"
#include "dypho/tools/camera_config.h"
#include "dypho/common/trajectory_io.h"

namespace dypho::tools {

/// A dataset folder or one of its files is missing or malformed; the message names the file.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One associated RGB-D pair.
struct DatasetEntry {
  double stamp_s = 0;        ///< colour image time [s], as written in rgb.txt
  Timestamp stamp_ns = 0;    ///< the same time in [ns], parsed exactly from the text
  double depth_stamp_s = 0;  ///< time of the associated depth image [s]
  std::string rgb_path;      ///< absolute path of the colour PNG
  std::string depth_path;    ///< absolute path of the 16-bit depth PNG
};

/// One line of rgb.txt / depth.txt.
struct StampedFile {
  double stamp_s = 0;      ///< time [s]
  Timestamp stamp_ns = 0;  ///< time [ns], parsed exactly from the text
  std::string path;        ///< file path as written (relative to the dataset folder)
};

/// Reads a TUM "timestamp filename" list ('#' comments). Throws DatasetError naming file:line.
/// With `skipped` (not null) a malformed line is skipped and described there ("file:line: ...")
/// instead of throwing: a recording with one bad line must not cost the whole run.
std::vector<StampedFile> readStampedFileList(const std::string& list_path, std::vector<std::string>* skipped = nullptr);

/// TUM associate.py rule: all (a, b) pairs with |a - b| < max_dt_s, taken greedily by smallest
/// difference (ties: smaller a, then smaller b), each element used at most once. Returns index
/// pairs (into `first`, into `second`) sorted by the stamp in `first`.
std::vector<std::pair<std::size_t, std::size_t>> associateStamps(const std::vector<double>& first,
                                                                 const std::vector<double>& second, double max_dt_s);

/// Parses a decimal seconds string ("1305031229.528748") to nanoseconds without rounding through a
/// double. Returns false when the text is not a plain decimal number.
bool parseSecondsToNs(const std::string& text, Timestamp* stamp_ns);

/// A TUM-layout dataset folder with its RGB-D associations.
class TumDataset {
 public:
  /// Reads rgb.txt, depth.txt (and groundtruth.txt if present) of `dir` and associates each rgb
  /// line with the nearest depth stamp within `max_dt_s` [s] (TUM associate rule). Throws
  /// DatasetError naming the missing/malformed file and line, or when no pair associates.
  static TumDataset open(const std::string& dir, const CameraConfig& camera, double max_dt_s = 0.02);

  /// Number of associated RGB-D pairs.
  std::size_t size() const { return entries_.size(); }
  /// Pair `i` (0 <= i < size(), else std::out_of_range).
  const DatasetEntry& entry(std::size_t i) const;
  /// Number of rgb.txt lines (associated or not).
  std::size_t numRgbLines() const { return num_rgb_lines_; }

  /// Loads pair `i`: BGR colour and depth_m = raw / depth_scale (0 stays 0), camera = config
  /// camera (distortion is NOT applied here). Unreadable PNG, wrong size or a depth PNG that is
  /// not 16UC1 -> DatasetError naming the file and the fix.
  RgbdFrame load(std::size_t i) const;

  /// Ground truth from groundtruth.txt as written (empty when the file is absent). For Bonn
  /// folders apply applyBonnCorrection() (evaluation.h) to get optical-centre poses.
  const std::vector<StampedPose>& groundtruth() const { return groundtruth_; }
  /// The dataset folder as given to open().
  const std::string& directory() const { return dir_; }
  /// Malformed rgb.txt / depth.txt lines that open() skipped, one message each ("file:line: ...").
  const std::vector<std::string>& skippedLines() const { return skipped_lines_; }
  /// The camera given to open().
  const CameraConfig& camera() const { return camera_; }

 private:
  TumDataset() = default;

  std::string dir_;
  CameraConfig camera_;
  std::vector<DatasetEntry> entries_;
  std::vector<StampedPose> groundtruth_;
  std::size_t num_rgb_lines_ = 0;
  std::vector<std::string> skipped_lines_;
};

}  // namespace dypho::tools
