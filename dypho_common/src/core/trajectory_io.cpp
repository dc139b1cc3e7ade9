#include "dypho/common/trajectory_io.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "dypho/common/atomic_file.h"

namespace dypho {

std::vector<StampedPose> readTumTrajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error("cannot open trajectory '" + path + "' (check the path)");
  }
  std::vector<StampedPose> poses;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    for (char& c : line) {
      if (c == ',' || c == '\t' || c == '\r') c = ' ';
    }
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos || line[first] == '#') continue;

    std::istringstream ss(line);
    double v[8];
    for (double& x : v) {
      if (!(ss >> x)) {
        throw std::runtime_error(path + ":" + std::to_string(line_no) +
                                 ": expected 8 numbers 'timestamp tx ty tz qx qy qz qw', got '" + line + "'");
      }
    }
    std::string rest;
    if (ss >> rest) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": unexpected extra text '" + rest +
                               "' after 8 numbers");
    }
    bool finite = true;
    for (double x : v) finite = finite && std::isfinite(x);
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (!finite || q.norm() < 1e-9) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": non-finite value or zero quaternion");
    }
    StampedPose p;
    p.stamp_s = v[0];
    p.T_world_camera.linear() = q.normalized().toRotationMatrix();
    p.T_world_camera.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    poses.push_back(p);
  }
  return poses;
}

void writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  writeFileAtomically(path, [&poses](std::ostream& out) {
    out << "# timestamp tx ty tz qx qy qz qw\n";
    char buf[256];
    for (const auto& p : poses) {
      Eigen::Quaterniond q(p.T_world_camera.rotation());
      if (q.w() < 0) q.coeffs() *= -1.0;
      const Eigen::Vector3d t = p.T_world_camera.translation();
      std::snprintf(buf, sizeof(buf), "%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", p.stamp_s, t.x(), t.y(), t.z(),
                    q.x(), q.y(), q.z(), q.w());
      out << buf;
    }
  });
}

}  // namespace dypho
