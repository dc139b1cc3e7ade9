#include "dypho/mapping/keyframe_cloud_map.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <stdexcept>
#include <thread>

#include <pcl/common/common.h>
#include <pcl/common/transforms.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>

#include <unistd.h>

namespace dypho {
namespace mapping {
namespace {

std::string sizeString(const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); }

void checkPose(const Eigen::Isometry3d& T, const std::string& what) {
  if (!T.matrix().allFinite()) {
    throw std::invalid_argument(what + ": pose T_world_camera has NaN/Inf entries");
  }
  const Eigen::Matrix3d R = T.linear();
  const double err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-4 || R.determinant() < 0.0) {
    throw std::invalid_argument(what +
                                ": pose T_world_camera is not a rigid transform "
                                "(rotation not orthonormal, |R^T R - I| = " +
                                std::to_string(err) + "); re-orthonormalise it");
  }
  const Eigen::RowVector4d last = T.matrix().row(3);
  if (!last.isApprox(Eigen::RowVector4d(0, 0, 0, 1))) {
    throw std::invalid_argument(what + ": pose T_world_camera has a last row other than 0 0 0 1");
  }
}

void checkKeyframe(const Keyframe& kf) {
  const std::string what = "KeyframeCloudMap::addKeyframe(id " + std::to_string(kf.id) + ")";
  if (kf.id < 0) throw std::invalid_argument(what + ": keyframe id must be >= 0");
  checkPose(kf.T_world_camera, what);
  const RgbdFrame& f = kf.frame;
  if (f.bgr.empty() || f.depth_m.empty()) {
    throw std::invalid_argument(what + ": empty " + (f.bgr.empty() ? "colour" : "depth") + " image");
  }
  if (f.bgr.type() != CV_8UC3) throw std::invalid_argument(what + ": colour must be CV_8UC3 (bgr8)");
  if (f.depth_m.type() != CV_32FC1) {
    throw std::invalid_argument(what + ": depth must be CV_32FC1 in metres (convert 16UC1 mm first)");
  }
  if (f.depth_m.size() != f.bgr.size()) {
    throw std::invalid_argument(what + ": depth " + sizeString(f.depth_m) + " does not match colour " +
                                sizeString(f.bgr));
  }
  if (!kf.mask.empty() && (kf.mask.type() != CV_8UC1 || kf.mask.size() != f.bgr.size())) {
    throw std::invalid_argument(what + ": mask must be CV_8UC1 of the colour size " + sizeString(f.bgr) + ", got " +
                                sizeString(kf.mask));
  }
  if (!f.camera.valid() || f.camera.width != f.bgr.cols || f.camera.height != f.bgr.rows) {
    throw std::invalid_argument(what + ": camera intrinsics invalid or not for a " + sizeString(f.bgr) +
                                " image (got " + std::to_string(f.camera.width) + "x" +
                                std::to_string(f.camera.height) + ")");
  }
}

/// Leaf that keeps PCL's voxel index count dx*dy*dz within int32 (with a factor-2 safety margin
/// for PCL's float arithmetic).
double safeLeaf(const Eigen::Vector4f& min_p, const Eigen::Vector4f& max_p, double leaf) {
  const double limit = static_cast<double>(std::numeric_limits<std::int32_t>::max()) / 2.0;
  for (int i = 0; i < 64; ++i) {
    double cells = 1.0;
    for (int k = 0; k < 3; ++k) cells *= std::floor((max_p[k] - min_p[k]) / leaf) + 1.0;
    if (cells <= limit) return leaf;
    leaf *= 1.25;
  }
  return leaf;
}

}  // namespace

KeyframeCloudMap::KeyframeCloudMap(const CloudMapOptions& options) : options_((options.validate(), options)) {}

std::size_t KeyframeCloudMap::addKeyframe(const Keyframe& keyframe) {
  checkKeyframe(keyframe);
  const RgbdFrame& f = keyframe.frame;
  const std::shared_ptr<const cv::Mat> rays = rays_.rays(f.camera);

  auto points = std::make_shared<Cloud>();
  const int stride = options_.pixel_stride;
  const float min_d = static_cast<float>(options_.min_depth_m);
  const float max_d = static_cast<float>(options_.max_depth_m);
  points->reserve(static_cast<std::size_t>((f.bgr.rows / stride + 1) * (f.bgr.cols / stride + 1)));
  for (int v = 0; v < f.bgr.rows; v += stride) {
    const float* depth = f.depth_m.ptr<float>(v);
    const cv::Vec3b* bgr = f.bgr.ptr<cv::Vec3b>(v);
    const cv::Vec2f* ray = rays->ptr<cv::Vec2f>(v);
    const unsigned char* mask = keyframe.mask.empty() ? nullptr : keyframe.mask.ptr<uchar>(v);
    for (int u = 0; u < f.bgr.cols; u += stride) {
      if (mask != nullptr && mask[u] != kMaskStatic) continue;
      const float d = depth[u];
      if (!std::isfinite(d) || d < min_d || d > max_d) continue;
      pcl::PointXYZRGB p;
      p.x = ray[u][0] * d;
      p.y = ray[u][1] * d;
      p.z = d;
      p.b = bgr[u][0];
      p.g = bgr[u][1];
      p.r = bgr[u][2];
      points->push_back(p);
    }
  }

  const auto existing = keyframes_.find(keyframe.id);
  const std::size_t replaced = existing != keyframes_.end() ? existing->second.points_camera->size() : 0;
  const std::size_t added = points->size();
  if (num_points_ - replaced + added > options_.max_points) {
    capacity_reached_ = true;
    return 0;
  }
  num_points_ = num_points_ - replaced + added;
  StoredKeyframe& stored = keyframes_[keyframe.id];
  stored.T_world_camera = keyframe.T_world_camera;
  stored.points_camera = std::move(points);
  return added;
}

bool KeyframeCloudMap::updateKeyframePose(std::int64_t id, const Eigen::Isometry3d& T_world_camera) {
  checkPose(T_world_camera, "KeyframeCloudMap::updateKeyframePose(id " + std::to_string(id) + ")");
  const auto it = keyframes_.find(id);
  if (it == keyframes_.end()) return false;
  it->second.T_world_camera = T_world_camera;
  return true;
}

KeyframeCloudSnapshot KeyframeCloudMap::snapshot() const {
  KeyframeCloudSnapshot s;
  s.keyframes.reserve(keyframes_.size());
  for (const auto& entry : keyframes_) s.keyframes.push_back({entry.second.T_world_camera, entry.second.points_camera});
  s.num_points = num_points_;
  s.voxel_size_m = options_.voxel_size_m;
  return s;
}

KeyframeCloudMap::Cloud::Ptr KeyframeCloudMap::buildCloud(CloudBuildReport* report) const {
  return mapping::buildCloud(snapshot(), report);
}

KeyframeCloudSnapshot::Cloud::Ptr buildCloud(const KeyframeCloudSnapshot& snapshot, CloudBuildReport* report) {
  using Cloud = KeyframeCloudSnapshot::Cloud;
  Cloud::Ptr world(new Cloud);
  world->reserve(snapshot.num_points);
  Cloud transformed;
  for (const KeyframeCloudSnapshot::Entry& entry : snapshot.keyframes) {
    pcl::transformPointCloud(*entry.points_camera, transformed, entry.T_world_camera.matrix().cast<float>());
    *world += transformed;
  }
  const double voxel_size_m = snapshot.voxel_size_m;
  CloudBuildReport local;
  CloudBuildReport& r = report != nullptr ? *report : local;
  r = CloudBuildReport();
  r.input_points = world->size();
  if (voxel_size_m <= 0.0 || world->empty()) {
    r.output_points = world->size();
    return world;
  }
  Eigen::Vector4f min_p, max_p;
  pcl::getMinMax3D(*world, min_p, max_p);
  r.leaf_size_m = safeLeaf(min_p, max_p, voxel_size_m);
  if (r.leaf_size_m != voxel_size_m) {
    r.coarser_leaf = true;
    r.message = "voxel_size_m " + std::to_string(voxel_size_m) +
                " would overflow pcl::VoxelGrid's 32-bit indices for a map extent of " +
                std::to_string(max_p[0] - min_p[0]) + " x " + std::to_string(max_p[1] - min_p[1]) + " x " +
                std::to_string(max_p[2] - min_p[2]) + " m; used leaf " + std::to_string(r.leaf_size_m) + " m instead";
  }
  Cloud::Ptr filtered(new Cloud);
  pcl::VoxelGrid<pcl::PointXYZRGB> grid;
  const float leaf = static_cast<float>(r.leaf_size_m);
  grid.setLeafSize(leaf, leaf, leaf);
  grid.setInputCloud(world);
  grid.filter(*filtered);
  r.output_points = filtered->size();
  return filtered;
}

void KeyframeCloudMap::savePcd(const std::string& path) const {
  namespace fs = std::filesystem;
  const std::string prefix = "KeyframeCloudMap::savePcd('" + path + "'): ";
  if (path.empty()) throw std::runtime_error(prefix + "empty path");
  const fs::path folder = fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw std::runtime_error(prefix + "folder '" + folder.string() + "' does not exist (create it first)");
  }
  const Cloud::Ptr cloud = buildCloud();
  const std::string tmp = path + ".tmp." + std::to_string(::getpid()) + "." +
                          std::to_string(std::hash<std::thread::id>()(std::this_thread::get_id()));
  int rc = -1;
  std::string detail;
  try {
    rc = pcl::io::savePCDFileBinary(tmp, *cloud);
  } catch (const std::exception& e) {
    detail = e.what();
  }
  if (rc != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(prefix + "writing the temporary file '" + tmp + "' failed (folder writable? disk full?) " +
                             detail);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(prefix + "cannot rename '" + tmp + "' to the target");
  }
}

void KeyframeCloudMap::reset() {
  keyframes_.clear();
  num_points_ = 0;
  capacity_reached_ = false;
}

}  // namespace mapping
}  // namespace dypho
