// The camera path of the paper's simulation (Zhou et al. 2008, §VI-A and Fig. 5): a
// piecewise polygonal 3-D path flown several times (two loops by default, so the second
// loop revisits what the first saw), sampled at poses equally spaced in arc length, with
// the camera rotating continually in all three angles.
//
// World frame: x and y horizontal, z up. The heading (rotation about the vertical) then
// lives in alpha of the ZYX Euler pose and may go all the way round the loop while beta
// stays near 0, far from the gimbal lock at beta = +-90 deg that a y-up world would hit
// every quarter turn. The camera frame is the usual x right, y down, z forward; a level
// camera has alpha = heading - 90 deg, beta = 0, gamma = -90 deg.
//
// Two kinds:
//  - kPolygon: a regular polygon whose vertices alternate in height; the heading turns
//    smoothly with the polar angle about the centre, so the camera sweeps steadily.
//  - kRectangle (Fig. 5c): the heading follows the current straight segment, so it jumps
//    by 90 deg at each corner: the sharp turns where the paper selects more frames.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose.h"

namespace ieslam {

enum class SimulatedTrajectoryKind { kPolygon, kRectangle };

const char* ToString(SimulatedTrajectoryKind kind);

struct PaperTrajectoryOptions {
  SimulatedTrajectoryKind kind = SimulatedTrajectoryKind::kPolygon;
  int num_poses = 300;  // over all loops, equally spaced in arc length
  int num_loops = 2;
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();

  int polygon_sides = 8;
  double polygon_radius_m = 5.0;     // centre to vertex
  double rectangle_length_m = 12.0;  // along world x
  double rectangle_width_m = 8.0;    // along world y

  // Vertex i sits at height +-amplitude (alternating), which makes the path 3-D.
  double vertex_height_amplitude_m = 0.8;
  // The path climbs this much per loop (centred on the volume), so that loops pass close
  // to, but not exactly through, the same places.
  double height_step_per_loop_m = 0.4;

  // The base heading is the direction of travel turned this much toward the centre
  // (the loop is flown counter-clockwise seen from above, so the centre is on the left).
  double look_inward_deg = 45.0;

  // Sinusoidal wobble on top of the base orientation: yaw about the vertical, pitch about
  // the camera's x axis, roll about its optical axis. Cycles per loop are whole numbers by
  // default so that every loop wobbles alike at the same place (loop closure sees the
  // same views).
  double yaw_wobble_deg = 15.0;
  double pitch_wobble_deg = 10.0;
  double roll_wobble_deg = 15.0;
  double yaw_cycles_per_loop = 3.0;
  double pitch_cycles_per_loop = 5.0;
  double roll_cycles_per_loop = 4.0;

  bool Check(std::string* why) const;
};

struct PaperTrajectory {
  std::vector<Vector6d> T_w_c;            // camera-to-world, one per pose
  std::vector<Eigen::Vector3d> vertices;  // the polyline, first to last (closed at the end)
  // For every interior vertex of the polyline, the first pose at or past it: the poses just
  // after a turn.
  std::vector<int> corner_poses;
  double length_m = 0.0;   // of the whole polyline, all loops
  double spacing_m = 0.0;  // arc length between consecutive poses
};

// Deterministic: the path has no random part. Throws ConfigError for options that fail
// Check().
PaperTrajectory BuildPaperTrajectory(const PaperTrajectoryOptions& options);

// Heading of the camera's optical axis projected on the horizontal plane, radians in
// (-pi, pi]: atan2 of its world y and x components.
double CameraHeading(const Vector6d& T_w_c);

}  // namespace ieslam
