/// The map scored at every Nth frame of a sequence (map_views.h).
#include "dypho/tools/map_views.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/mapping/map_renderer.h"

namespace dypho::tools {
namespace {

constexpr double kStampToleranceS = 1e-3;  ///< TUM files keep 6 decimals; any frame is >= 10 ms apart

/// The entry of `by_stamp` within kStampToleranceS of `stamp_s`, or end().
template <typename Value>
typename std::map<double, Value>::const_iterator nearestStamp(const std::map<double, Value>& by_stamp, double stamp_s) {
  auto best = by_stamp.end();
  auto it = by_stamp.lower_bound(stamp_s - kStampToleranceS);
  for (; it != by_stamp.end() && it->first <= stamp_s + kStampToleranceS; ++it) {
    if (best == by_stamp.end() || std::abs(it->first - stamp_s) < std::abs(best->first - stamp_s)) best = it;
  }
  return best;
}

}  // namespace

std::string MapViewRun::notes() const {
  std::ostringstream os;
  os << frames_chosen << " frames chosen, " << evaluation.views.size() << " scored, " << frames_without_pose
     << " without a pose, " << frames_unreadable << " unreadable, " << frames_without_mask
     << " scored without a mask (all pixels)";
  return os.str();
}

MapViewRun evaluateMapViews(const mapping::GaussianMap& map, const FrameSource& source, std::size_t num_frames,
                            const std::vector<StampedPose>& trajectory, const std::vector<double>& keyframe_stamps_s,
                            const ViewMaskLookup& mask_of, const mapping::ViewEvaluationOptions& options,
                            int num_threads) {
  options.validate();
  std::map<double, Eigen::Isometry3d> poses;
  for (const StampedPose& p : trajectory) poses[p.stamp_s] = p.T_world_camera;
  std::map<double, bool> keyframes;
  for (double s : keyframe_stamps_s) keyframes[s] = true;
  mapping::MapRenderer renderer(std::max(1, num_threads));
  MapViewRun run;
  std::vector<mapping::ViewScore> scores;
  const std::size_t step = static_cast<std::size_t>(options.every_nth_frame);
  for (std::size_t i = 0; i < std::min(num_frames, source.size()); i += step) {
    ++run.frames_chosen;
    SourceFrame sf;
    try {
      sf = source.load(i);
    } catch (const std::exception&) {
      ++run.frames_unreadable;
      continue;
    }
    const double stamp_s = timestampToSeconds(sf.frame.stamp_ns);
    const auto pose = nearestStamp(poses, stamp_s);
    if (pose == poses.end()) {
      ++run.frames_without_pose;
      continue;
    }
    cv::Mat mask = mask_of ? mask_of(i, sf.frame.stamp_ns) : cv::Mat();
    if (mask.empty()) ++run.frames_without_mask;
    if (!mask.empty() && mask.size() != sf.frame.bgr.size()) {
      cv::resize(mask, mask, sf.frame.bgr.size(), 0, 0, cv::INTER_NEAREST);  // a mask at working resolution
    }
    const mapping::RenderedView view = renderer.render(map, pose->second, sf.frame.camera);
    mapping::ViewScore score = mapping::scoreView(view, sf.frame.bgr, sf.frame.depth_m, mask, options);
    score.stamp_ns = sf.frame.stamp_ns;
    score.keyframe = nearestStamp(keyframes, stamp_s) != keyframes.end();
    scores.push_back(score);
  }
  run.evaluation = mapping::summarizeViews(std::move(scores));
  return run;
}

ViewMaskLookup masksFromFolder(const std::string& dir) {
  const std::string list = dir + "/mask.txt";
  std::ifstream in(list);
  if (!in) throw std::runtime_error("cannot read " + list + " (write masks with dypho_run_dataset --save-masks)");
  auto files = std::make_shared<std::map<double, std::string>>();
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    double stamp_s = 0.0;
    std::string file;
    if (!(ls >> stamp_s >> file)) throw std::runtime_error(list + ": malformed line '" + line + "'");
    (*files)[stamp_s] = dir + "/" + file;
  }
  return [files](std::size_t, Timestamp stamp_ns) -> cv::Mat {
    const auto it = nearestStamp(*files, timestampToSeconds(stamp_ns));
    if (it == files->end()) return cv::Mat();
    cv::Mat mask = cv::imread(it->second, cv::IMREAD_GRAYSCALE);
    if (mask.empty()) throw std::runtime_error("cannot read mask " + it->second);
    return mask;
  };
}

}  // namespace dypho::tools
