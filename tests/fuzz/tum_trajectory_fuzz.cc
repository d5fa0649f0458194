// Fuzzes the TUM trajectory reader (`t tx ty tz qx qy qz qw` lines). Besides crashes and
// sanitizer reports, aborts when a trajectory it accepts breaks what it promises (finite,
// strictly increasing, rotations orthonormal) or does not survive being written and read back.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/trajectory.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  ieslam::Trajectory trajectory;
  try {
    trajectory = ieslam::ParseTumTrajectory(in, "trajectory.txt");
  } catch (const ieslam::DataError& e) {
    Require(std::string(e.what()).rfind("trajectory.txt:", 0) == 0);  // names file and line
    return 0;
  }
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const ieslam::TimedPose& pose = trajectory[i];
    Require(std::isfinite(pose.timestamp));
    Require(i == 0 || pose.timestamp > trajectory[i - 1].timestamp);
    Require(pose.T_w_c.matrix().allFinite());
    const Eigen::Matrix3d R = pose.T_w_c.linear();
    Require((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-9);
    // What we write, we read back: the same pose to the printed precision.
    const std::string line = ieslam::FormatTumLine(pose);
    const ieslam::TimedPose back = ieslam::ParseTumPoseLine(line, "written");
    const double scale = 1.0 + pose.T_w_c.translation().norm();
    Require((back.T_w_c.translation() - pose.T_w_c.translation()).norm() <= 1e-8 * scale);
    Require((back.T_w_c.linear() - R).norm() < 1e-7);
  }
  return 0;
}
