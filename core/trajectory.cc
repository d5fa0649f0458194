#include "core/trajectory.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/file_util.h"
#include "core/input_file.h"

namespace ieslam {

std::optional<Eigen::Isometry3d> InterpolatePose(const Trajectory& trajectory, double timestamp,
                                                 double max_gap_s) {
  constexpr double kSameStamp = 1e-6;
  const auto after =
      std::lower_bound(trajectory.begin(), trajectory.end(), timestamp,
                       [](const TimedPose& pose, double t) { return pose.timestamp < t; });
  if (after != trajectory.end() && after->timestamp - timestamp < kSameStamp) return after->T_w_c;
  if (after != trajectory.begin() && timestamp - std::prev(after)->timestamp < kSameStamp) {
    return std::prev(after)->T_w_c;
  }
  if (after == trajectory.begin() || after == trajectory.end()) return std::nullopt;
  const TimedPose& a = *std::prev(after);
  const TimedPose& b = *after;
  if (b.timestamp - a.timestamp > max_gap_s) return std::nullopt;
  const double s = (timestamp - a.timestamp) / (b.timestamp - a.timestamp);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(a.T_w_c.linear())
                   .slerp(s, Eigen::Quaterniond(b.T_w_c.linear()))
                   .toRotationMatrix();
  T.translation() = (1.0 - s) * a.T_w_c.translation() + s * b.T_w_c.translation();
  return T;
}

TimedPose ParseTumPoseLine(std::string line, const std::string& where) {
  std::replace(line.begin(), line.end(), ',', ' ');
  std::istringstream fields(line);
  double v[8];
  for (double& value : v) {
    std::string token;
    if (!(fields >> token)) {
      throw DataError(where + ": expected 8 values `t tx ty tz qx qy qz qw`, got: " + line);
    }
    char* end = nullptr;
    value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      throw DataError(where + ": not a number: '" + token + "'");
    }
    if (!std::isfinite(value)) throw DataError(where + ": non-finite value '" + token + "'");
  }
  const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
  if (q.norm() < 0.5 || q.norm() > 1.5) {
    throw DataError(where + ": quaternion is far from unit length (norm " +
                    std::to_string(q.norm()) + ")");
  }
  TimedPose pose;
  pose.timestamp = v[0];
  pose.T_w_c.linear() = q.normalized().toRotationMatrix();
  pose.T_w_c.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
  return pose;
}

Trajectory ReadTumTrajectory(const std::string& path) {
  RequireRegularInputFile(path, "trajectory file", kMaxListFileBytes);
  std::ifstream in(path);
  if (!in) throw DataError("cannot open trajectory file " + path);
  return ParseTumTrajectory(in, path);
}

Trajectory ParseTumTrajectory(std::istream& in, const std::string& path) {
  Trajectory trajectory;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string where = path + ":" + std::to_string(line_number);
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const TimedPose pose = ParseTumPoseLine(line, where);
    if (!trajectory.empty() && !(pose.timestamp > trajectory.back().timestamp)) {
      std::ostringstream s;
      s.precision(6);
      s << std::fixed << where << ": timestamps must increase strictly, got " << pose.timestamp
        << " after " << trajectory.back().timestamp;
      throw DataError(s.str());
    }
    trajectory.push_back(pose);
  }
  return trajectory;
}

std::string FormatTumLine(const TimedPose& pose) {
  Eigen::Quaterniond q(pose.T_w_c.linear());
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // one sign for q and -q, so files compare equal
  const Eigen::Vector3d& t = pose.T_w_c.translation();
  // Sized by a first call: a huge value prints hundreds of digits (1e308 with %.9f: 309
  // before the point), which a fixed buffer would cut.
  const char* const format = "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f";
  const int size = std::snprintf(nullptr, 0, format, pose.timestamp, t.x(), t.y(), t.z(), q.x(),
                                 q.y(), q.z(), q.w());
  std::string line(static_cast<size_t>(size) + 1, '\0');
  std::snprintf(line.data(), line.size(), format, pose.timestamp, t.x(), t.y(), t.z(), q.x(), q.y(),
                q.z(), q.w());
  line.resize(static_cast<size_t>(size));
  return line;
}

void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory,
                        const std::string& comment) {
  WriteFileAtomically(path, [&](std::ostream& out) {
    if (!comment.empty()) out << "# " << comment << "\n";
    for (const TimedPose& pose : trajectory) out << FormatTumLine(pose) << "\n";
  });
}

}  // namespace ieslam
