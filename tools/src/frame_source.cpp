#include "dypho/tools/frame_source.h"

#include <sys/stat.h>

#include <opencv2/imgcodecs.hpp>

#include "dypho/tools/camera_config.h"
#include "dypho/tools/tum_dataset.h"

namespace dypho::tools {
namespace {

bool isDirectory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

std::string baseName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

class FolderFrameSource : public FrameSource {
 public:
  FolderFrameSource(TumDataset dataset, std::string camera_name, double rolling_shutter_readout_ms)
      : dataset_(std::move(dataset)),
        camera_name_(std::move(camera_name)),
        rolling_shutter_readout_ms_(rolling_shutter_readout_ms),
        mask_dir_(dataset_.directory() + "/mask"),
        has_masks_(isDirectory(mask_dir_)) {}

  std::size_t size() const override { return dataset_.size(); }

  SourceFrame load(std::size_t i) const override {
    SourceFrame sf;
    sf.frame = dataset_.load(i);
    if (has_masks_) {
      const std::string path = mask_dir_ + "/" + baseName(dataset_.entry(i).rgb_path);
      sf.mask = cv::imread(path, cv::IMREAD_UNCHANGED);
      if (sf.mask.empty() || sf.mask.type() != CV_8UC1 || sf.mask.size() != sf.frame.bgr.size()) {
        throw std::runtime_error("mask '" + path + "' is missing or not an 8-bit single-channel " +
                                 "image of the colour size");
      }
    }
    return sf;
  }

  const std::vector<StampedPose>& groundtruth() const override { return dataset_.groundtruth(); }
  std::string cameraName() const override { return camera_name_; }
  double rollingShutterReadoutMs() const override { return rolling_shutter_readout_ms_; }
  bool hasMasks() const override { return has_masks_; }
  std::string description() const override { return "folder " + dataset_.directory(); }
  std::vector<std::string> warnings() const override { return dataset_.skippedLines(); }

 private:
  TumDataset dataset_;
  std::string camera_name_;
  double rolling_shutter_readout_ms_;
  std::string mask_dir_;
  bool has_masks_;
};

}  // namespace

std::unique_ptr<FrameSource> openFrameSource(const std::string& path, const std::string& camera,
                                             const std::string& config_dir) {
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".bag") == 0) {
    return openBagFrameSource(path, camera, config_dir);
  }
  if (!isDirectory(path)) {
    throw std::runtime_error("dataset '" + path + "' is neither a folder nor a .bag file that " +
                             "exists (check the path)");
  }
  std::string camera_name = camera;
  if (camera_name.empty()) {
    const auto detected = detectCameraName(path);
    if (!detected) {
      std::string known;
      for (const auto& n : listCameraNames(config_dir)) known += " " + n;
      throw std::runtime_error("cannot tell which camera recorded '" + path + "': pass --camera with one of:" + known +
                               " or a camera YAML path");
    }
    camera_name = *detected;
  }
  const CameraConfig config = loadCameraConfig(resolveCameraConfig(camera_name, config_dir));
  return std::make_unique<FolderFrameSource>(TumDataset::open(path, config),
                                             config.name.empty() ? camera_name : config.name,
                                             config.rolling_shutter_readout_ms);
}

}  // namespace dypho::tools
