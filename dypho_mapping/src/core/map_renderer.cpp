/// MapRenderer: a Gaussian map rendered at a pose, mapped into the (possibly distorted) camera.
#include "dypho/mapping/map_renderer.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace dypho::mapping {

GaussianParamsView<float> paramsView(const GaussianMap& map) {
  GaussianParamsView<float> p;
  p.position = map.data(kParamPosition);
  p.log_scale = map.data(kParamLogScale);
  p.rotation = map.data(kParamRotation);
  p.opacity_logit = map.data(kParamOpacity);
  p.sh = map.data(kParamSh);
  p.count = static_cast<int>(map.size());
  p.sh_degree = map.shDegree();
  return p;
}

MapRenderer::MapRenderer(int num_threads, ComputeDevice device)
    : pool_(num_threads),  // also the fallback after a CUDA failure
      raster_(&pool_),
      cuda_(device == ComputeDevice::kCuda ? std::make_unique<CudaRasterizer>() : nullptr) {}

RenderedView MapRenderer::render(const GaussianMap& map, const Eigen::Isometry3d& T_world_camera,
                                 const CameraIntrinsics& camera) {
  return renderImpl(map, nullptr, T_world_camera, camera);
}

RenderedView MapRenderer::render(const std::shared_ptr<const GaussianMap>& snapshot,
                                 const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) {
  if (!snapshot) throw std::invalid_argument("MapRenderer::render: null map snapshot");
  return renderImpl(*snapshot, &snapshot, T_world_camera, camera);
}

cv::Mat MapRenderer::renderDepth(const std::shared_ptr<const GaussianMap>& snapshot,
                                 const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) {
  return render(snapshot, T_world_camera, camera).depth_m;
}

RenderedView MapRenderer::renderImpl(const GaussianMap& map, const std::shared_ptr<const GaussianMap>* snapshot,
                                     const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) {
  if (!camera.valid()) throw std::invalid_argument("MapRenderer::render: invalid camera intrinsics");
  if (!T_world_camera.matrix().allFinite()) throw std::invalid_argument("MapRenderer::render: pose is not finite");
  CameraIntrinsics pinhole = camera;
  pinhole.distortion = {0, 0, 0, 0, 0};
  bool rendered = false;
  if (cuda_) {
    try {
      if (snapshot == nullptr || *snapshot != on_device_) {
        on_device_.reset();
        cuda_->setParams(paramsView(map));
        on_device_ = snapshot != nullptr ? *snapshot : nullptr;
      }
      cuda_->forwardUploaded(makePinholeView<float>(T_world_camera, pinhole), out_);
      rendered = true;
    } catch (const std::runtime_error& e) {  // a CUDA failure: the CPU renders from now on
      device_fallback_ = std::string("CUDA render failed (") + e.what() + "); rendering on the CPU";
      cuda_.reset();
      on_device_.reset();
    }
  }
  if (!rendered) raster_.forward(paramsView(map), makePinholeView<float>(T_world_camera, pinhole), out_);
  const RenderResult<float>& r = out_;
  const std::size_t npix = static_cast<std::size_t>(r.width) * r.height;
  RenderedView view;
  view.bgr.create(r.height, r.width, CV_8UC3);
  view.depth_m.create(r.height, r.width, CV_32FC1);
  view.alpha.create(r.height, r.width, CV_32FC1);
  for (int v = 0; v < r.height; ++v) {
    cv::Vec3b* c = view.bgr.ptr<cv::Vec3b>(v);
    float* d = view.depth_m.ptr<float>(v);
    float* a = view.alpha.ptr<float>(v);
    for (int u = 0; u < r.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * r.width + u;
      for (int ch = 0; ch < 3; ++ch)
        c[u][2 - ch] = cv::saturate_cast<std::uint8_t>(r.color[ch * npix + i] * 255.f + 0.5f);
      a[u] = r.alpha[i];
      d[u] = r.alpha[i] >= 0.5f ? r.depth[i] / r.alpha[i] : 0.f;
    }
  }
  if (!camera.distorted()) return view;
  // Distorted pixel (u, v) sees ray (x, y, 1): its pinhole pixel is (fx x + cx, fy y + cy).
  const std::shared_ptr<const cv::Mat> rays = rays_.rays(camera);
  cv::Mat map_px(camera.height, camera.width, CV_32FC2);
  for (int v = 0; v < camera.height; ++v) {
    const cv::Vec2f* ray = rays->ptr<cv::Vec2f>(v);
    cv::Vec2f* m = map_px.ptr<cv::Vec2f>(v);
    for (int u = 0; u < camera.width; ++u)
      m[u] = cv::Vec2f(static_cast<float>(camera.fx * ray[u][0] + camera.cx),
                       static_cast<float>(camera.fy * ray[u][1] + camera.cy));
  }
  RenderedView distorted;
  cv::remap(view.bgr, distorted.bgr, map_px, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::remap(view.depth_m, distorted.depth_m, map_px, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
  cv::remap(view.alpha, distorted.alpha, map_px, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  return distorted;
}

cv::Mat MapRenderer::renderDepth(const GaussianMap& map, const Eigen::Isometry3d& T_world_camera,
                                 const CameraIntrinsics& camera) {
  return render(map, T_world_camera, camera).depth_m;
}

}  // namespace dypho::mapping
