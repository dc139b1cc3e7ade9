// Bag input for dypho_run_dataset (built only with ROS; see frame_source_nobag.cpp otherwise).
#include <sys/stat.h>

#include "dypho/tools/bag_io.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/frame_source.h"

namespace dypho::tools {
namespace {

class BagFrameSource : public FrameSource {
 public:
  BagFrameSource(const std::string& path, std::optional<CameraConfig> camera)
      : path_(path), reader_(path), camera_(std::move(camera)) {
    if (camera_) reader_.setCamera(camera_->camera);  // --camera overrides the bag's camera_info
    // A groundtruth.txt next to the bag (as dypho_synth writes it) is used for evaluation.
    const auto slash = path.find_last_of('/');
    const std::string gt = (slash == std::string::npos ? std::string(".") : path.substr(0, slash)) + "/groundtruth.txt";
    struct stat st {};
    if (::stat(gt.c_str(), &st) == 0) groundtruth_ = readTumTrajectory(gt);
  }

  std::size_t size() const override { return reader_.size(); }

  SourceFrame load(std::size_t i) const override {
    SourceFrame sf;
    sf.frame = reader_.load(i);
    return sf;
  }

  const std::vector<StampedPose>& groundtruth() const override { return groundtruth_; }
  std::string cameraName() const override { return camera_ ? camera_->name : "camera_info"; }
  double rollingShutterReadoutMs() const override { return camera_ ? camera_->rolling_shutter_readout_ms : 0.0; }
  bool hasMasks() const override { return false; }
  std::string description() const override { return "bag " + path_; }

 private:
  std::string path_;
  BagRgbdReader reader_;
  std::optional<CameraConfig> camera_;
  std::vector<StampedPose> groundtruth_;
};

}  // namespace

std::unique_ptr<FrameSource> openBagFrameSource(const std::string& bag_path, const std::string& camera,
                                                const std::string& config_dir) {
  std::optional<CameraConfig> config;
  if (!camera.empty()) config = loadCameraConfig(resolveCameraConfig(camera, config_dir));
  return std::make_unique<BagFrameSource>(bag_path, config);
}

}  // namespace dypho::tools
