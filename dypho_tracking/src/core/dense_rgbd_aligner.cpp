/// DenseRgbdAligner: photometric + depth alignment to the reference keyframe with a feature prior.
#include "dypho/tracking/dense_rgbd_aligner.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <opencv2/imgproc.hpp>

#include "dense_image.h"
#include "dypho/common/rounding.h"

namespace dypho {
namespace tracking {
namespace {

using Row6 = Eigen::Matrix<double, 1, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

constexpr float kNoValue = std::numeric_limits<float>::quiet_NaN();
/// Fewest residuals at a level for a step; fewer leave the pose where it is [count].
constexpr int kMinResiduals = 60;

/// t-distribution weight of a residual of `sigmas` standard deviations (DVO-SLAM), zero beyond
/// `max_sigmas`.
double tWeight(double sigmas, double dof, double max_sigmas) {
  if (std::abs(sigmas) > max_sigmas) return 0.0;
  return (dof + 1.0) / (dof + sigmas * sigmas);
}

/// The depth edge threshold at depth z [m]: neighbours further apart belong to different surfaces.
double edgeToleranceM(const DenseAlignerSettings& s, double z) { return std::max(0.03, 4.0 * depthSigmaM(s, z)); }

/// A surface measured this much nearer than a sample's predicted depth hides it (a person in
/// front) [m]: generous, so that a pose still off by some centimetres keeps its samples.
double occlusionToleranceM(double z) { return std::max(0.1, 0.05 * z); }

/// Pixel (x, y) of `depth_m` has a valid depth and four valid neighbours on the same surface.
bool smoothDepth(const DenseAlignerSettings& s, const cv::Mat& depth_m, int x, int y) {
  const float z = depth_m.at<float>(y, x);
  if (!dense::validDepth(z)) return false;
  const float n[4] = {depth_m.at<float>(y, x - 1), depth_m.at<float>(y, x + 1), depth_m.at<float>(y - 1, x),
                      depth_m.at<float>(y + 1, x)};
  const double tolerance = edgeToleranceM(s, z);
  for (float v : n) {
    if (!dense::validDepth(v) || std::abs(v - z) > tolerance) return false;
  }
  return true;
}

/// Central-difference depth gradients [m/px]; NaN where the depth is not smooth.
void depthGradients(const DenseAlignerSettings& s, const cv::Mat& depth_m, cv::Mat* gx, cv::Mat* gy) {
  gx->create(depth_m.size(), CV_32F);
  gy->create(depth_m.size(), CV_32F);
  gx->setTo(kNoValue);
  gy->setTo(kNoValue);
  for (int y = 1; y < depth_m.rows - 1; ++y) {
    for (int x = 1; x < depth_m.cols - 1; ++x) {
      if (!smoothDepth(s, depth_m, x, y)) continue;
      gx->at<float>(y, x) = 0.5f * (depth_m.at<float>(y, x + 1) - depth_m.at<float>(y, x - 1));
      gy->at<float>(y, x) = 0.5f * (depth_m.at<float>(y + 1, x) - depth_m.at<float>(y - 1, x));
    }
  }
}

/// Every `stride`-th of `candidates`, so that at most `max_count` remain.
template <typename T>
std::vector<T> thinned(const std::vector<T>& candidates, int max_count) {
  const std::size_t stride = std::max<std::size_t>(
      1, (candidates.size() + static_cast<std::size_t>(max_count) - 1) / static_cast<std::size_t>(max_count));
  std::vector<T> out;
  for (std::size_t i = 0; i < candidates.size(); i += stride) out.push_back(candidates[i]);
  return out;
}

}  // namespace

double depthSigmaM(const DenseAlignerSettings& settings, double z_m) {
  return std::max(settings.depth_sigma_floor_m, settings.depth_sigma_per_m2 * z_m * z_m);
}

/// Weighted normal equations of one Gauss-Newton step.
struct DenseRgbdAligner::NormalEquations {
  PoseInformation H = PoseInformation::Zero();
  Vector6 g = Vector6::Zero();
  int photometric = 0;
  int depth = 0;
  void add(const Row6& j, double residual, double weight) {
    H.noalias() += weight * j.transpose() * j;
    g.noalias() += weight * j.transpose() * residual;
  }
};

DenseRgbdAligner::DenseRgbdAligner(const DenseAlignerSettings& settings)
    : settings_(settings),
      levels_(static_cast<std::size_t>(std::max(1, settings.levels))),
      undistort_(levels_.size()) {}

void DenseRgbdAligner::clear() {
  reference_id_ = -1;
  for (Level& level : levels_) level = Level();
}

double DenseRgbdAligner::levelScale(int level) const { return settings_.scale / static_cast<double>(1 << level); }

void DenseRgbdAligner::sampleReference(const cv::Mat& grey, const cv::Mat& depth_m, const cv::Mat& mask,
                                       Level* level) const {
  cv::Mat gx, gy;
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
  const float min_sq = static_cast<float>(settings_.min_gradient * settings_.min_gradient);
  std::vector<cv::Point> photometric, depth;
  for (int y = 2; y < grey.rows - 2; ++y) {
    for (int x = 2; x < grey.cols - 2; ++x) {
      if (mask.at<uchar>(y, x) != 0 || !smoothDepth(settings_, depth_m, x, y)) continue;
      depth.emplace_back(x, y);
      const float ax = gx.at<float>(y, x), ay = gy.at<float>(y, x);
      if (ax * ax + ay * ay > min_sq) photometric.emplace_back(x, y);
    }
  }
  level->photometric_p_reference_m.clear();
  level->grey_reference.clear();
  level->depth_p_reference_m.clear();
  for (const cv::Point& c : thinned(photometric, settings_.max_photometric_samples)) {
    level->photometric_p_reference_m.push_back(
        level->pinhole.backProject(Eigen::Vector2d(c.x, c.y), depth_m.at<float>(c.y, c.x)));
    level->grey_reference.push_back(grey.at<float>(c.y, c.x));
  }
  for (const cv::Point& c : thinned(depth, settings_.max_depth_samples)) {
    level->depth_p_reference_m.push_back(
        level->pinhole.backProject(Eigen::Vector2d(c.x, c.y), depth_m.at<float>(c.y, c.x)));
  }
}

bool DenseRgbdAligner::setReference(std::int64_t keyframe_id, const RgbdFrame& frame, const cv::Mat& mask) {
  clear();
  if (frame.bgr.empty() || frame.depth_m.empty() || !frame.camera.valid()) return false;
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    cv::Mat grey, depth, mask_small;
    dense::reduce(frame, mask, levelScale(static_cast<int>(l)), &undistort_[l], &grey, &depth, &mask_small);
    levels_[l].pinhole = dense::reducedPinhole(frame, grey);
    sampleReference(grey, depth, mask_small, &levels_[l]);
  }
  const Level& finest = levels_.front();
  if (finest.photometric_p_reference_m.size() + finest.depth_p_reference_m.size() < 2 * kMinResiduals) {
    clear();
    return false;
  }
  reference_id_ = keyframe_id;
  return true;
}

void DenseRgbdAligner::setCurrent(const RgbdFrame& frame, const cv::Mat& mask) {
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    Level& level = levels_[l];
    dense::reduce(frame, mask, levelScale(static_cast<int>(l)), &undistort_[l], &level.grey, &level.depth_m,
                  &level.mask);
    cv::Sobel(level.grey, level.grad_x, CV_32F, 1, 0, 3, 1.0 / 8.0);
    cv::Sobel(level.grey, level.grad_y, CV_32F, 0, 1, 3, 1.0 / 8.0);
    depthGradients(settings_, level.depth_m, &level.depth_grad_x, &level.depth_grad_y);
  }
}

void DenseRgbdAligner::addPhotometric(const Level& level, const Eigen::Isometry3d& T, NormalEquations* ne,
                                      double* sigma) const {
  const std::size_t n = level.photometric_p_reference_m.size();
  std::vector<double> residuals;
  std::vector<Row6> jacobians;
  residuals.reserve(n);
  jacobians.reserve(n);
  const double fx = level.pinhole.fx, fy = level.pinhole.fy;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d q = T * level.photometric_p_reference_m[i];
    if (q.z() < 0.05) continue;
    const Eigen::Vector2d uv = level.pinhole.project(q);
    if (!dense::insideForBilinear(level.grey, uv.x(), uv.y())) continue;
    const int u = roundHalfAway(uv.x()), v = roundHalfAway(uv.y());
    if (level.mask.at<uchar>(v, u) != 0) continue;
    // Occluded by something nearer (a person in front): not this sample's surface.
    const float z = level.depth_m.at<float>(v, u);
    if (dense::validDepth(z) && z < q.z() - occlusionToleranceM(q.z())) continue;
    const dense::BilinearPoint at(uv.x(), uv.y());
    const double gx = at.sample(level.grad_x), gy = at.sample(level.grad_y);
    const double iz = 1.0 / q.z();
    const Eigen::Vector3d dr_dq(gx * fx * iz, gy * fy * iz, -(gx * fx * q.x() + gy * fy * q.y()) * iz * iz);
    jacobians.push_back(leftJacobian(q, dr_dq));
    residuals.push_back(at.sample(level.grey) - level.grey_reference[i]);
  }
  if (residuals.size() < static_cast<std::size_t>(kMinResiduals)) return;
  std::vector<double> sorted = residuals;
  const double offset = dense::median(&sorted);  // exposure change between the two images
  for (double& r : sorted) r = std::abs(r - offset);
  *sigma = std::max(settings_.photometric_sigma_floor, 1.4826 * dense::median(&sorted));
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    const double e = residuals[i] - offset;
    const double w = tWeight(e / *sigma, settings_.t_dof, settings_.max_residual_sigmas) / (*sigma * *sigma);
    if (w > 0.0) ne->add(jacobians[i], e, w);
    ne->photometric += w > 0.0;
  }
}

void DenseRgbdAligner::addDepth(const Level& level, const Eigen::Isometry3d& T, NormalEquations* ne) const {
  const double fx = level.pinhole.fx, fy = level.pinhole.fy;
  std::vector<double> sigmas;  // residuals in units of the sensor's depth noise
  std::vector<Row6> jacobians;
  std::vector<double> inv_sigma;
  for (const Eigen::Vector3d& p : level.depth_p_reference_m) {
    const Eigen::Vector3d q = T * p;
    if (q.z() < 0.05) continue;
    const Eigen::Vector2d uv = level.pinhole.project(q);
    if (!dense::insideForBilinear(level.depth_m, uv.x(), uv.y())) continue;
    if (level.mask.at<uchar>(static_cast<int>(uv.y()), static_cast<int>(uv.x())) != 0) continue;
    // The four depths around the sample lie on one smooth surface: their gradients exist.
    const double dx = dense::bilinear(level.depth_grad_x, uv.x(), uv.y());
    const double dy = dense::bilinear(level.depth_grad_y, uv.x(), uv.y());
    if (!std::isfinite(dx) || !std::isfinite(dy)) continue;
    const double e = dense::bilinear(level.depth_m, uv.x(), uv.y()) - q.z();
    // Both depths carry the sensor noise: the reference's at the sample, the current's at q.
    const double sigma = std::hypot(depthSigmaM(settings_, p.z()), depthSigmaM(settings_, q.z()));
    const double iz = 1.0 / q.z();
    const Eigen::Vector3d dr_dq(dx * fx * iz, dy * fy * iz, -(dx * fx * q.x() + dy * fy * q.y()) * iz * iz - 1.0);
    sigmas.push_back(e / sigma);
    jacobians.push_back(leftJacobian(q, dr_dq));
    inv_sigma.push_back(1.0 / sigma);
  }
  if (sigmas.size() < static_cast<std::size_t>(kMinResiduals)) return;
  // While the pose is still off (coarse levels), residuals are larger than the sensor's noise:
  // the robust spread of the normalised residuals widens the weights until it is the noise.
  std::vector<double> spread(sigmas.size());
  for (std::size_t i = 0; i < sigmas.size(); ++i) spread[i] = std::abs(sigmas[i]);
  const double k = std::max(1.0, 1.4826 * dense::median(&spread));
  for (std::size_t i = 0; i < sigmas.size(); ++i) {
    const double w = tWeight(sigmas[i] / k, settings_.t_dof, settings_.max_residual_sigmas);
    if (w <= 0.0) continue;
    const double s = inv_sigma[i] / k;
    ne->add(jacobians[i] * s, sigmas[i] / k, w);
    ++ne->depth;
  }
}

bool DenseRgbdAligner::step(const Level& level, const DensePosePrior& prior, Eigen::Isometry3d* T,
                            DenseAlignment* out) const {
  NormalEquations ne;
  double sigma = 0.0;
  addPhotometric(level, *T, &ne, &sigma);
  addDepth(level, *T, &ne);
  if (ne.photometric + ne.depth < kMinResiduals) {
    out->message = "dense alignment: " + std::to_string(ne.photometric + ne.depth) + " residuals (need " +
                   std::to_string(kMinResiduals) + ")";
    return false;
  }
  out->photometric_samples = ne.photometric;
  out->depth_samples = ne.depth;
  out->photometric_sigma = sigma;
  out->information = ne.H;
  // The prior pulls towards its pose: e = log(T T_prior^-1) to first order.
  const Eigen::Isometry3d T_error = *T * prior.T_current_reference.inverse();
  const Eigen::AngleAxisd rotation_error(T_error.rotation());
  Vector6 e;
  e << T_error.translation(), rotation_error.angle() * rotation_error.axis();
  PoseInformation H = ne.H + prior.information;
  const Vector6 g = ne.g + prior.information * e;
  H.diagonal() *= 1.0 + 1e-6;
  const Vector6 delta = -H.ldlt().solve(g);
  if (!delta.allFinite()) {
    out->message = "dense alignment: singular normal equations";
    return false;
  }
  *T = dense::leftStep(delta) * *T;
  return delta.head<3>().norm() > 1e-6 || delta.tail<3>().norm() > 1e-6;
}

DenseAlignment DenseRgbdAligner::align(const Eigen::Isometry3d& T_current_reference_init,
                                       const DensePosePrior& prior) const {
  DenseAlignment out;
  out.T_current_reference = T_current_reference_init;
  if (reference_id_ < 0 || levels_.front().grey.empty()) {
    out.message = "dense alignment: no reference keyframe or no current frame";
    return out;
  }
  Eigen::Isometry3d T = T_current_reference_init;
  for (int l = static_cast<int>(levels_.size()) - 1; l >= 0; --l) {
    const Level& level = levels_[static_cast<std::size_t>(l)];
    bool ok = true;
    for (int it = 0; it < settings_.iterations && ok; ++it) {
      out.message.clear();
      ok = step(level, prior, &T, &out);
    }
    if (!out.message.empty() && l == 0) return out;  // too few residuals at the finest level
  }
  if (!T.matrix().allFinite()) {
    out.message = "dense alignment: the pose is not finite";
    return out;
  }
  out.T_current_reference = T;
  out.success = true;
  return out;
}

}  // namespace tracking
}  // namespace dypho
