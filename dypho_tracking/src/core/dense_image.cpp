/// Image helpers shared by the dense steps of tracking (dense_image.h).
#include "dense_image.h"

#include <algorithm>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace dypho {
namespace tracking {
namespace dense {

void reduce(const RgbdFrame& frame, const cv::Mat& mask, double scale, UndistortMaps* maps, cv::Mat* grey,
            cv::Mat* depth_m, cv::Mat* mask_small) {
  const cv::Size size(std::max(8, static_cast<int>(std::lround(frame.bgr.cols * scale))),
                      std::max(8, static_cast<int>(std::lround(frame.bgr.rows * scale))));
  cv::Mat g8;
  if (frame.bgr.channels() == 3) {
    cv::cvtColor(frame.bgr, g8, cv::COLOR_BGR2GRAY);
  } else {
    g8 = frame.bgr;
  }
  cv::Mat g;
  cv::resize(g8, g, size, 0, 0, cv::INTER_AREA);
  g.convertTo(*grey, CV_32F);
  cv::resize(frame.depth_m, *depth_m, size, 0, 0, cv::INTER_NEAREST);
  if (mask.empty()) {
    *mask_small = cv::Mat::zeros(size, CV_8UC1);
  } else {
    cv::resize(mask, *mask_small, size, 0, 0, cv::INTER_AREA);
    cv::threshold(*mask_small, *mask_small, 0, 255, cv::THRESH_BINARY);
  }
  if (!frame.camera.distorted()) return;
  // Undistorted onto the same scaled pinhole that the samples use (sx, sy as scaledPinhole).
  const double sx = static_cast<double>(size.width) / frame.bgr.cols,
               sy = static_cast<double>(size.height) / frame.bgr.rows;
  const cv::Matx33d K(frame.camera.fx * sx, 0.0, (frame.camera.cx + 0.5) * sx - 0.5, 0.0, frame.camera.fy * sy,
                      (frame.camera.cy + 0.5) * sy - 0.5, 0.0, 0.0, 1.0);
  if (maps->map_x.size() != size || !sameCamera(maps->camera, frame.camera)) {  // computed once per camera
    const cv::Mat D(1, 5, CV_64F, const_cast<double*>(frame.camera.distortion.data()));
    cv::initUndistortRectifyMap(K, D, cv::noArray(), K, size, CV_32FC1, maps->map_x, maps->map_y);
    maps->camera = frame.camera;
  }
  cv::Mat grey_out, depth_out, mask_out;  // separate outputs: remap reuses buffers
  cv::remap(*grey, grey_out, maps->map_x, maps->map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::remap(*depth_m, depth_out, maps->map_x, maps->map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  // Outside the distorted image: no depth, and marked dynamic so that nothing is compared there.
  cv::remap(*mask_small, mask_out, maps->map_x, maps->map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(255));
  *grey = grey_out;
  *depth_m = depth_out;
  *mask_small = mask_out;
}

Eigen::Isometry3d leftStep(const Eigen::Matrix<double, 6, 1>& delta) {
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  const double angle = delta.tail<3>().norm();
  if (angle > 1e-12) step.linear() = Eigen::AngleAxisd(angle, delta.tail<3>() / angle).toRotationMatrix();
  step.translation() = delta.head<3>();
  return step;
}

}  // namespace dense
}  // namespace tracking
}  // namespace dypho
