#include "dypho/tools/slam_pipeline.h"

#include <chrono>
#include <iostream>
#include <fstream>
#include <stdexcept>

#include "dypho/mapping/mapping_options_fields.h"
#include "dypho/mask/mask_options_fields.h"
#include "dypho/tools/options_yaml.h"
#include "dypho/tracking/tracking_options_fields.h"

namespace dypho::tools {
namespace {

/// The Gaussian mapper with its worker running (queue of 4 keyframes; process() blocks beyond).
std::unique_ptr<mapping::GaussianMapper> startGaussianMapper(const mapping::GaussianMapperOptions& options) {
  auto mapper = std::make_unique<mapping::GaussianMapper>(options);
  mapper->setMessageSink([](const std::string& m) { std::cerr << "mapping: " << m << "\n"; });
  mapper->start(4);
  return mapper;
}

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

YAML::Node loadYamlFile(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error("cannot read config file '" + path + "' (does it exist?)");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("config file '" + path + "' is not valid YAML: " + e.what());
  }
}

template <typename Options>
void readSection(const YAML::Node& node, const std::string& context, Options& options) {
  YamlOptionsReader reader(node, context);
  visitOptions(options, reader);
  reader.checkNoUnknownKeys();
}

}  // namespace

MaskSource parseMaskSource(const std::string& name) {
  if (name == "flow") return MaskSource::kFlow;
  if (name == "external" || name == "gt") return MaskSource::kExternal;
  if (name == "none") return MaskSource::kNone;
  throw std::runtime_error("unknown mask source '" + name + "' (valid: flow, gt, none)");
}

PipelineOptions loadPipelineOptions(const std::string& config_dir, const std::string& override_yaml) {
  PipelineOptions options;
  readSection(loadYamlFile(config_dir + "/mask.yaml"), config_dir + "/mask.yaml", options.mask);
  readSection(loadYamlFile(config_dir + "/tracking.yaml"), config_dir + "/tracking.yaml",
              options.tracking);
  readSection(loadYamlFile(config_dir + "/mapping.yaml"), config_dir + "/mapping.yaml",
              options.mapping);
  if (!override_yaml.empty()) {
    const YAML::Node root = loadYamlFile(override_yaml);
    if (root.IsDefined() && !root.IsNull()) {
      if (!root.IsMap()) throw std::runtime_error(override_yaml + ": expected mask:/tracking:/mapping: maps");
      for (const auto& kv : root) {
        const std::string section = kv.first.as<std::string>();
        if (section != "mask" && section != "tracking" && section != "mapping") {
          throw std::runtime_error(override_yaml + ": unknown section '" + section +
                                   "' (valid: mask, tracking, mapping)");
        }
      }
      readSection(root["mask"], override_yaml + " [mask]", options.mask);
      readSection(root["tracking"], override_yaml + " [tracking]", options.tracking);
      readSection(root["mapping"], override_yaml + " [mapping]", options.mapping);
    }
  }
  try {
    options.mask.validate();
    options.tracking.validate();
    options.mapping.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("invalid option: ") + e.what());
  }
  return options;
}

void writePipelineOptionsYaml(std::ostream& out, PipelineOptions options) {
  out << "mask:\n";
  mask::visitOptions(options.mask, YamlOptionsWriter(out, 2));
  out << "tracking:\n";
  tracking::visitOptions(options.tracking, YamlOptionsWriter(out, 2));
  out << "mapping:\n";
  mapping::visitOptions(options.mapping, YamlOptionsWriter(out, 2));
}

SlamPipeline::SlamPipeline(const PipelineOptions& options)
    : options_(options),
      masker_(options.mask),
      odometry_(options.tracking),
      map_(options.mapping.cloud),
      gaussian_map_(startGaussianMapper(options.mapping.gaussian)) {
  if (!options.mask.yolo.model_path.empty() && !masker_.segmentReady()) {
    std::cerr << "warning: " << masker_.segmentStatus() << "\n";  // once, at start-up
  }
}

mask::MaskPrior SlamPipeline::predictMaskPrior(const RgbdFrame& frame) const {
  mask::MaskPrior prior;
  if (T_world_prev_ && T_world_prevprev_) {
    // Constant velocity: the coming step repeats the last one, T_prev_cur = T_pp_p.
    prior.T_prev_cur = T_world_prevprev_->inverse() * *T_world_prev_;
    prior.rendered_depth_m = renderPredictedDepth(frame, *T_world_prev_ * *prior.T_prev_cur);
  }
  return prior;
}

cv::Mat SlamPipeline::renderPredictedDepth(const RgbdFrame& /*frame*/,
                                           const Eigen::Isometry3d& /*T_world_camera_pred*/) const {
  // The Gaussian map can render this (GaussianMapper::renderDepth), but it trains on a worker
  // thread, so a render here would make in-process runs depend on thread timing. Until rendering
  // is tied to the training schedule the background model runs without the R_d term in
  // dypho_run_dataset; the ROS graph feeds it through the rendered/depth_predicted topic.
  return cv::Mat();
}

FrameReport SlamPipeline::process(const RgbdFrame& frame, const cv::Mat& external_mask) {
  FrameReport report;
  cv::Mat mask;
  const auto t_mask = std::chrono::steady_clock::now();
  if (options_.mask_source == MaskSource::kFlow) {
    mask::MaskResult result = masker_.compute(frame, predictMaskPrior(frame));
    mask = result.mask;
    report.masked_fraction = result.degraded ? 0.0 : result.masked_fraction;
    report.mask_degraded = result.degraded;
  } else if (options_.mask_source == MaskSource::kExternal && !external_mask.empty()) {
    mask = external_mask;
    report.masked_fraction = static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total());
  }
  report.mask_ms = msSince(t_mask);

  report.tracking = odometry_.track(frame, mask);
  if (report.tracking.state == tracking::TrackingState::kOk) {
    T_world_prevprev_ = T_world_prev_;
    T_world_prev_ = report.tracking.T_world_camera;
  } else {
    T_world_prev_.reset();  // no trusted motion: the mask falls back to its homography
    T_world_prevprev_.reset();
  }

  if (report.tracking.keyframe) {
    const auto t_map = std::chrono::steady_clock::now();
    map_.addKeyframe(*report.tracking.keyframe);
    gaussian_map_->enqueueKeyframe(report.tracking.keyframe, /*block_when_full=*/true);
    report.mapping_ms = msSince(t_map);
  }
  // Loop closure moved earlier keyframes: re-anchor them in the maps; the motion prior restarts.
  for (const auto& [keyframe_id, T_world_keyframe] : report.tracking.corrected_keyframes) {
    map_.updateKeyframePose(keyframe_id, T_world_keyframe);
    gaussian_map_->updateKeyframePose(keyframe_id, T_world_keyframe);
  }
  if (report.tracking.loop_closed) T_world_prevprev_.reset();
  return report;
}

}  // namespace dypho::tools
