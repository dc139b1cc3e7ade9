#include "dypho/mask/ego_motion.h"

#include <cmath>
#include <limits>

namespace dypho {
namespace mask {

void predictRigidPrevious(const cv::Mat& cur_px, const cv::Mat& depth_m, const CameraIntrinsics& camera,
                          const Eigen::Isometry3d& T_prev_cur, cv::Mat& predicted_prev_px) {
  CV_Assert(cur_px.type() == CV_32FC2 && depth_m.type() == CV_32FC1 && cur_px.size() == depth_m.size() &&
            camera.fx > 0.0 && camera.fy > 0.0);
  predicted_prev_px.create(cur_px.size(), CV_32FC2);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Matrix3d R = T_prev_cur.linear();
  const Eigen::Vector3d t = T_prev_cur.translation();
  const double ifx = 1.0 / camera.fx, ify = 1.0 / camera.fy;
  for (int y = 0; y < cur_px.rows; ++y) {
    const cv::Vec2f* c = cur_px.ptr<cv::Vec2f>(y);
    const float* d = depth_m.ptr<float>(y);
    cv::Vec2f* p = predicted_prev_px.ptr<cv::Vec2f>(y);
    for (int x = 0; x < cur_px.cols; ++x) {
      const float z = d[x];
      if (!(z > 0.f) || !std::isfinite(c[x][0])) {  // also rejects NaN depth
        p[x] = cv::Vec2f(nan, nan);
        continue;
      }
      const Eigen::Vector3d X_cur(z * (c[x][0] - camera.cx) * ifx, z * (c[x][1] - camera.cy) * ify, z);
      const Eigen::Vector3d X_prev = R * X_cur + t;
      if (X_prev.z() <= 0.01) {
        p[x] = cv::Vec2f(nan, nan);
        continue;
      }
      p[x] = cv::Vec2f(static_cast<float>(camera.fx * X_prev.x() / X_prev.z() + camera.cx),
                       static_cast<float>(camera.fy * X_prev.y() / X_prev.z() + camera.cy));
    }
  }
}

}  // namespace mask
}  // namespace dypho
