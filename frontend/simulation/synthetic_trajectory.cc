#include "frontend/simulation/synthetic_trajectory.h"

#include <cmath>
#include <sstream>

#include <glog/logging.h>

#include "core/error.h"

namespace ieslam {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Fixed phases, so that the wobbles do not all pass through zero at the first frame.
constexpr double kSwayPhase = 0.4, kBobPhase = 1.3, kYawPhase = 2.1, kPitchPhase = 0.7,
                 kRollPhase = 2.9;

}  // namespace

bool SyntheticTrajectoryOptions::Check(std::string* why) const {
  std::ostringstream s;
  const double amplitudes[] = {radial_sway_m, height_bob_m, yaw_wobble_deg, pitch_wobble_deg,
                               roll_wobble_deg};
  const int cycles[] = {radial_sway_cycles, height_bob_cycles, yaw_wobble_cycles,
                        pitch_wobble_cycles, roll_wobble_cycles};
  bool amplitudes_ok = true, cycles_ok = true;
  for (double a : amplitudes) amplitudes_ok = amplitudes_ok && std::isfinite(a) && a >= 0.0;
  for (int c : cycles) cycles_ok = cycles_ok && c >= 0 && c <= 100;
  if (!centre_m.allFinite() || !radii_m.allFinite() || !(radii_m.minCoeff() >= 0.0)) {
    s << "centre_m and radii_m must be finite, radii non-negative, got radii "
      << radii_m.transpose();
  } else if (!(height_m > 0.0) || !std::isfinite(height_m)) {
    s << "height_m must be positive, got " << height_m;
  } else if (!(radial_sway_m <= radii_m.minCoeff() || radii_m.minCoeff() == 0.0)) {
    s << "radial_sway_m (" << radial_sway_m << ") must not exceed the smaller radius";
  } else if (!std::isfinite(look_offset_deg) || !(std::fabs(pitch_deg + pitch_wobble_deg) < 80.0) ||
             !(std::fabs(pitch_deg - pitch_wobble_deg) < 80.0)) {
    s << "pitch_deg +- pitch_wobble_deg must stay within +-80 deg, got " << pitch_deg << " +- "
      << pitch_wobble_deg;
  } else if (!amplitudes_ok) {
    s << "wobble amplitudes must be finite and non-negative";
  } else if (!cycles_ok) {
    s << "wobble cycles must be whole numbers in [0, 100] (the loop must close)";
  } else {
    return true;
  }
  if (why != nullptr) *why = s.str();
  return false;
}

Eigen::Matrix3d LookRotation(double heading, double pitch, double roll) {
  // Columns: the camera's x (right), y (down), z (forward) axes in the world for a camera
  // looking along world +x.
  Eigen::Matrix3d looking_along_x;
  looking_along_x << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return (Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()))
             .toRotationMatrix() *
         looking_along_x * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Isometry3d SyntheticTrajectoryPose(const SyntheticTrajectoryOptions& o, double i,
                                          int frames) {
  CHECK_GE(frames, 1);
  const double phi = 2.0 * M_PI * i / frames;
  auto wave = [phi](double amplitude, int cycles, double phase) {
    return amplitude * std::sin(cycles * phi + phase);
  };
  const double sway = wave(o.radial_sway_m, o.radial_sway_cycles, kSwayPhase);
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
  T_w_c.translation() << o.centre_m.x() + (o.radii_m.x() + sway) * std::cos(phi),
      o.centre_m.y() + (o.radii_m.y() + sway) * std::sin(phi),
      o.height_m + wave(o.height_bob_m, o.height_bob_cycles, kBobPhase);
  const double heading =
      phi +
      (o.look_offset_deg + wave(o.yaw_wobble_deg, o.yaw_wobble_cycles, kYawPhase)) * kDegToRad;
  const double pitch =
      (o.pitch_deg + wave(o.pitch_wobble_deg, o.pitch_wobble_cycles, kPitchPhase)) * kDegToRad;
  const double roll = wave(o.roll_wobble_deg, o.roll_wobble_cycles, kRollPhase) * kDegToRad;
  T_w_c.linear() = LookRotation(heading, pitch, roll);
  return T_w_c;
}

std::vector<Eigen::Isometry3d> BuildSyntheticTrajectory(const SyntheticTrajectoryOptions& options,
                                                        int frames) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("synthetic trajectory options: " + why);
  CHECK_GE(frames, 1);
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(frames);
  for (int i = 0; i < frames; ++i) poses.push_back(SyntheticTrajectoryPose(options, i, frames));
  return poses;
}

}  // namespace ieslam
