// Trajectories in the TUM RGB-D format: one pose per line, `t tx ty tz qx qy qz qw`
// (camera-to-world, unit quaternion with w last), `#` comments and blank lines allowed.
#pragma once

#include <istream>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace ieslam {

struct TimedPose {
  double timestamp = 0.0;  // seconds
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
};

using Trajectory = std::vector<TimedPose>;

// The pose at `timestamp` between the two samples around it (translation linearly, rotation
// by slerp; a sample within 1 us of `timestamp` as it is). nullopt outside the trajectory or
// where those samples are more than `max_gap_s` apart: a ground truth with a dropout does not
// vouch for the poses inside it. `trajectory` is sorted by time.
std::optional<Eigen::Isometry3d> InterpolatePose(const Trajectory& trajectory, double timestamp,
                                                 double max_gap_s);

// One pose line `t tx ty tz qx qy qz qw` (commas count as spaces, as in TUM's tools). Throws
// DataError prefixed with `where` (file:line) for missing or non-numeric values, NaN/inf, or a
// quaternion far from unit length; the quaternion is normalised.
TimedPose ParseTumPoseLine(std::string line, const std::string& where);

// Reads a TUM trajectory. Throws DataError naming the file and line for a malformed line,
// NaN/inf values, a zero quaternion, or timestamps that are not strictly increasing.
// Quaternions are normalised (files print them to 4-6 decimals).
Trajectory ReadTumTrajectory(const std::string& path);
// The same from a stream; `path` names it in messages.
Trajectory ParseTumTrajectory(std::istream& in, const std::string& path);

// Writes atomically with 6-decimal timestamps and 9-decimal values; `comment` (without
// the leading '#') becomes the first line when non-empty.
void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory,
                        const std::string& comment = "");

// One line in TUM format, without a newline.
std::string FormatTumLine(const TimedPose& pose);

}  // namespace ieslam
