// A smooth, hand-held-like closed-loop camera path for the synthetic room
// (frontend/simulation/synthetic_scene.h): the camera walks once round an ellipse about the room's
// centre looking outwards, at the walls and at what stands along them 1-3 m away, while
// sinusoids make it sway sideways, bob up and down, and wobble in yaw, pitch and roll.
//
// Every sinusoid has a whole number of cycles per loop, so the path is periodic: frame N
// would be frame 0 again, and the last frames revisit what the first ones saw (a loop
// closure). With the defaults and 300 frames (10 s at 30 Hz) the camera moves ~2 cm and
// turns ~1.5 deg per frame, like a hand-held Kinect; fewer frames mean larger steps.
//
// World frame z up; camera frame x right, y down, z forward (core/camera.h).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ieslam {

struct SyntheticTrajectoryOptions {
  Eigen::Vector2d centre_m{0.0, 0.0};  // of the ellipse, horizontal
  Eigen::Vector2d radii_m{1.1, 0.75};  // semi-axes along world x and y
  double height_m = 1.35;              // of the optical centre above the floor
  // Heading relative to the outward direction from the centre: the camera looks obliquely
  // ahead of its motion, so that consecutive views share most of the scene.
  double look_offset_deg = 25.0;
  double pitch_deg = -12.0;  // negative: looking down a little (boxes and floor in view)

  double radial_sway_m = 0.06;
  int radial_sway_cycles = 5;
  double height_bob_m = 0.08;
  int height_bob_cycles = 3;
  double yaw_wobble_deg = 8.0;
  int yaw_wobble_cycles = 2;
  double pitch_wobble_deg = 5.0;
  int pitch_wobble_cycles = 3;
  double roll_wobble_deg = 4.0;
  int roll_wobble_cycles = 4;

  bool Check(std::string* why) const;
};

// T_w_c of the camera at frame i of `frames` evenly spaced round the loop; a fractional i is a
// time between frames (the path is smooth in i).
Eigen::Isometry3d SyntheticTrajectoryPose(const SyntheticTrajectoryOptions& options, double i,
                                          int frames);

// All `frames` poses (frames >= 1). Throws ConfigError for options failing Check().
std::vector<Eigen::Isometry3d> BuildSyntheticTrajectory(const SyntheticTrajectoryOptions& options,
                                                        int frames);

// The camera rotation of a level camera (x right, y down, z forward) whose optical axis has
// heading `heading` (radians from world x towards y) and elevation `pitch` (radians, up
// positive), rolled by `roll` about the optical axis.
Eigen::Matrix3d LookRotation(double heading, double pitch, double roll);

}  // namespace ieslam
