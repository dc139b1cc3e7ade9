/// OdomFrame: REP-105's map -> odom takes the pose's jumps, odom -> camera stays smooth.
#include <gtest/gtest.h>

#include "dypho/tracking/odom_frame.h"

namespace dypho::tracking {
namespace DYPHO_UNITY_ID {

Eigen::Isometry3d pose(double x, double y, double z, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Eigen::Vector3d(x, y, z));
  T.rotate(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()));
  return T;
}

double distance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff();
}

// Without jumps map -> odom is the tracker's own (loop corrections only); at a relocalisation the
// camera jumps 2 m in the map, odom -> camera keeps its last value and map -> odom takes the
// jump; after it the odometry goes on smoothly from there. map -> odom * odom -> camera is the
// published pose throughout (1e-12: a composition of rigid transforms).
TEST(OdomFrame, MapToOdomTakesTheJumpAndOdomToCameraStaysSmooth) {
  OdomFrame odom;
  const Eigen::Isometry3d loop = pose(0.1, 0, 0, 0.05);  // the tracker's T_world_odom
  Eigen::Isometry3d T_map_odom = odom.update(pose(0, 0, 0, 0), loop, false);
  EXPECT_LT(distance(T_map_odom, loop), 1e-12);
  T_map_odom = odom.update(pose(0.01, 0, 0, 0), loop, false);
  const Eigen::Isometry3d T_odom_camera_before = T_map_odom.inverse() * pose(0.01, 0, 0, 0);

  const Eigen::Isometry3d T_map_found = pose(2.0, 0, 1.0, 0.8);
  T_map_odom = odom.update(T_map_found, loop, /*jumped=*/true);
  EXPECT_LT(distance(T_map_odom.inverse() * T_map_found, T_odom_camera_before), 1e-12);
  EXPECT_GT((T_map_odom.translation() - loop.translation()).norm(), 1.0);

  // 1 cm on in the map: 1 cm on in odom, map -> odom unchanged.
  const Eigen::Isometry3d T_map_next = T_map_found * pose(0.01, 0, 0, 0);
  const Eigen::Isometry3d T_map_odom_next = odom.update(T_map_next, loop, false);
  EXPECT_LT(distance(T_map_odom_next, T_map_odom), 1e-12);
  EXPECT_LT(distance(T_map_odom_next.inverse() * T_map_next, T_odom_camera_before * pose(0.01, 0, 0, 0)), 1e-12);

  // A new world: odom is the tracker's again.
  odom.reset();
  EXPECT_LT(distance(odom.update(T_map_found, loop, true), loop), 1e-12);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::tracking
