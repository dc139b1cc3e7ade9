/// makePinholeView: the rasterizers' camera from a pose and OpenCV-style intrinsics (kept out of
/// rasterizer.cpp so that the rasterizer builds without OpenCV, see standalone/).
#include "dypho/common/camera.h"
#include "dypho/mapping/rasterizer.h"

namespace dypho::mapping {

template <typename T>
gs::PinholeView<T> makePinholeView(const Eigen::Isometry3d& T_world_camera, const CameraIntrinsics& camera) {
  gs::PinholeView<T> v{};
  v.fx = T(camera.fx);
  v.fy = T(camera.fy);
  v.cx = T(camera.cx);
  v.cy = T(camera.cy);
  v.width = camera.width;
  v.height = camera.height;
  const Eigen::Isometry3d T_cw = T_world_camera.inverse();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) v.R_cw[i][j] = T(T_cw.linear()(i, j));
    v.t_cw[i] = T(T_cw.translation()(i));
    v.center_w[i] = T(T_world_camera.translation()(i));
  }
  return v;
}
template gs::PinholeView<float> makePinholeView<float>(const Eigen::Isometry3d&, const CameraIntrinsics&);
template gs::PinholeView<double> makePinholeView<double>(const Eigen::Isometry3d&, const CameraIntrinsics&);

}  // namespace dypho::mapping
