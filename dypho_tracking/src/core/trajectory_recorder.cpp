#include "dypho/tracking/trajectory_recorder.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace dypho {
namespace tracking {

void TrajectoryRecorder::add(const TrackingResult& result) {
  if (result.state == TrackingState::kNotInitialized) return;  // no world yet: no pose
  RecordedPose r;
  r.stamp_ns = result.stamp_ns;
  r.reference_keyframe_id = result.state == TrackingState::kOk ? result.reference_keyframe_id : std::int64_t{-1};
  r.T_reference_camera = result.T_reference_camera;
  r.T_world_camera_online = result.T_world_camera;
  r.discontinuous = result.discontinuous;
  records_.push_back(r);
}

namespace {

using PoseList = std::vector<std::pair<Timestamp, Eigen::Isometry3d>>;

/// Median of the length of a 3-D isotropic Gaussian vector (chi distribution, 3 degrees of
/// freedom), in units of its per-axis sigma.
constexpr double kChi3MedianSigmas = 1.5382;
/// Fits after the first that re-weigh the positions by their distance to the previous fit.
constexpr int kReweightRounds = 3;

/// The weighted least-squares line p(t) = a + b t (t relative to pose k) through the positions of
/// pose k's segment within +-half_window_s, evaluated at pose k (a); nullopt for a pose that is
/// not smoothed (segment -1) or whose window holds fewer than three poses or no time spread.
std::optional<Eigen::Vector3d> fitAt(const PoseList& raw, const std::vector<int>& segment_ids, double half_window_s,
                                     const std::vector<double>& weights, std::size_t k) {
  if (segment_ids[k] < 0) return std::nullopt;
  const auto seconds = [&](std::size_t j) { return 1e-9 * static_cast<double>(raw[j].first - raw[k].first); };
  const auto inWindow = [&](std::size_t j) {
    return segment_ids[j] == segment_ids[k] && std::abs(seconds(j)) <= half_window_s;
  };
  std::size_t first = k, last = k;  // a segment's poses are consecutive
  while (first > 0 && inWindow(first - 1)) --first;
  while (last + 1 < raw.size() && inWindow(last + 1)) ++last;
  if (last - first < 2) return std::nullopt;
  double n = 0.0, sum_t = 0.0, sum_tt = 0.0;
  Eigen::Vector3d sum_p = Eigen::Vector3d::Zero(), sum_tp = Eigen::Vector3d::Zero();
  for (std::size_t j = first; j <= last; ++j) {
    const double t = seconds(j), w = weights[j];
    n += w;
    sum_t += w * t;
    sum_tt += w * t * t;
    sum_p += w * raw[j].second.translation();
    sum_tp += w * t * raw[j].second.translation();
  }
  const double det = n * sum_tt - sum_t * sum_t;
  if (!(det > 1e-12 * n * n)) return std::nullopt;
  return Eigen::Vector3d((sum_tt * sum_p - sum_t * sum_tp) / det);
}

std::vector<std::optional<Eigen::Vector3d>> fitAll(const PoseList& raw, const std::vector<int>& segment_ids,
                                                   double half_window_s, const std::vector<double>& weights) {
  std::vector<std::optional<Eigen::Vector3d>> fits(raw.size());
  for (std::size_t k = 0; k < raw.size(); ++k) fits[k] = fitAt(raw, segment_ids, half_window_s, weights, k);
  return fits;
}

/// Huber weights from each fitted position's distance to its fit: 1 within outlier_sigmas sigma,
/// falling as 1 / distance beyond; sigma from the median distance of all fitted positions.
/// Returns false, weights unchanged, when there is no spread to judge by (fewer than five fitted
/// positions, or a median of zero).
bool huberWeights(const PoseList& raw, const std::vector<std::optional<Eigen::Vector3d>>& fits, double outlier_sigmas,
                  std::vector<double>* weights) {
  std::vector<double> distance_m(raw.size(), 0.0), fitted_m;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    if (!fits[k]) continue;
    distance_m[k] = (raw[k].second.translation() - *fits[k]).norm();
    fitted_m.push_back(distance_m[k]);
  }
  if (fitted_m.size() < 5) return false;
  const auto middle = fitted_m.begin() + static_cast<std::ptrdiff_t>(fitted_m.size() / 2);
  std::nth_element(fitted_m.begin(), middle, fitted_m.end());
  const double sigma_m = *middle / kChi3MedianSigmas;
  if (!(sigma_m > 0.0)) return false;
  const double limit_m = outlier_sigmas * sigma_m;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    if (fits[k]) (*weights)[k] = distance_m[k] > limit_m ? limit_m / distance_m[k] : 1.0;
  }
  return true;
}

}  // namespace

PositionSmoothing positionSmoothing(const TrackingOptions& options) {
  return PositionSmoothing{options.trajectory_smoothing_s, options.trajectory_smoothing_outlier_sigmas};
}

void smoothPositions(const PositionSmoothing& smoothing, const std::vector<int>& segment_ids, PoseList* poses) {
  if (!(smoothing.half_window_s > 0.0) || poses->size() != segment_ids.size()) return;
  const PoseList raw = *poses;
  std::vector<double> weights(raw.size(), 1.0);
  std::vector<std::optional<Eigen::Vector3d>> fits = fitAll(raw, segment_ids, smoothing.half_window_s, weights);
  for (int round = 0; smoothing.outlier_sigmas > 0.0 && round < kReweightRounds; ++round) {
    if (!huberWeights(raw, fits, smoothing.outlier_sigmas, &weights)) break;
    fits = fitAll(raw, segment_ids, smoothing.half_window_s, weights);
  }
  for (std::size_t k = 0; k < raw.size(); ++k) {
    if (fits[k]) (*poses)[k].second.translation() = *fits[k];
  }
}

std::vector<std::pair<Timestamp, Eigen::Isometry3d>> TrajectoryRecorder::finalPoses(const TrackerMap& map,
                                                                                    const PositionSmoothing& smoothing,
                                                                                    std::size_t first_record) const {
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> out;
  std::vector<int> segment_ids;
  out.reserve(records_.size());
  segment_ids.reserve(records_.size());
  int segment = 0;
  for (std::size_t i = first_record; i < records_.size(); ++i) {
    const RecordedPose& r = records_[i];
    const std::optional<Eigen::Isometry3d> T_world_reference =
        r.reference_keyframe_id >= 0 ? map.keyframePose(r.reference_keyframe_id) : std::nullopt;
    out.emplace_back(r.stamp_ns,
                     T_world_reference ? *T_world_reference * r.T_reference_camera : r.T_world_camera_online);
    if (r.discontinuous) ++segment;
    if (T_world_reference) {
      segment_ids.push_back(segment);
    } else {  // lost or from a forgotten world: kept as it is, and the motion after it is another
      segment_ids.push_back(-1);
      ++segment;
    }
  }
  smoothPositions(smoothing, segment_ids, &out);
  return out;
}

std::vector<std::pair<Timestamp, Eigen::Isometry3d>> TrajectoryRecorder::onlinePoses() const {
  std::vector<std::pair<Timestamp, Eigen::Isometry3d>> out;
  out.reserve(records_.size());
  for (const RecordedPose& r : records_) out.emplace_back(r.stamp_ns, r.T_world_camera_online);
  return out;
}

}  // namespace tracking
}  // namespace dypho
