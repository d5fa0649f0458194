// Rolling-shutter compensation of a frame's lifted keypoints.
//
// A rolling-shutter camera exposes its rows one after the other (Rig::colour_readout_s from
// the first to the last), so a frame taken while the camera turns is not one view from one
// pose: each row sees the scene from where the camera was at that row's time. A keypoint on
// row y, lifted through the range image, is the point p seen from the camera at time
// t + tau(y). With the camera's velocity over the frame taken as constant (angular velocity w
// and linear velocity v, both in the camera frame at the frame's timestamp t), the pose at
// t + tau relative to the one at t is T(tau) = (exp(tau w), tau v), and the point seen from the
// frame's own pose is T(tau) p. Keypoints moved so describe one view from one pose, as the
// filter's observation model (eqs. 4-8) and the 3-D registration assume.
//
// The velocity is not measured: it is estimated from the frame's registrations to the frames
// before and after it in the sequence (VelocityOfFrame), whose relative poses over their time
// steps are the camera's mean velocity between them.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera.h"
#include "core/range_cloud.h"
#include "core/trajectory.h"
#include "frontend/lifting.h"

namespace ieslam {

// A camera's velocity in its own frame (x right, y down, z forward).
struct CameraVelocity {
  Eigen::Vector3d angular_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear_m_s = Eigen::Vector3d::Zero();
};

// The constant velocity that takes a camera from pose a to pose b (T_a_b: p_a = T_a_b p_b) in
// dt > 0 seconds, to first order in the motion: the rotation vector of R_a_b and t_a_b, over dt.
CameraVelocity VelocityBetween(const Eigen::Isometry3d& T_a_b, double dt);

// The velocity at a frame from its motion relative to the frames before (T_prev_frame over
// dt_before) and after it (T_frame_next over dt_after), either of which may be missing: the
// mean of the two when both are there (a central difference, exact to second order for a
// smoothly moving camera), else the one there is; none without either.
std::optional<CameraVelocity> VelocityOfFrame(const std::optional<Eigen::Isometry3d>& T_prev_frame,
                                              double dt_before,
                                              const std::optional<Eigen::Isometry3d>& T_frame_next,
                                              double dt_after);

// The camera's pose at time offset tau relative to its pose at the reference time
// (p_reference = T * p_at_tau), the velocity held constant over tau.
Eigen::Isometry3d MotionOver(const CameraVelocity& velocity, double tau);

// The lifted point of a keypoint on distorted pixel row `row`, moved into the camera frame of
// the frame's timestamp: p_c, its observation z = (u, v, d) (undistorted pixel and range) and
// their covariances are those of the moved point. An invalid point is returned unchanged.
LiftedPoint CompensateRollingShutter(const LiftedPoint& point, double row,
                                     const CameraVelocity& velocity, const Rig& rig);

// The velocity of each frame of a sequence, estimated once from its registrations to the
// frames next to it (VelocityOfFrame) and then kept, so that a frame processed again is
// compensated alike whatever was processed in between. Each step's registration (frame k-1
// to frame k) is asked for once and serves both of its frames.
class FrameVelocities {
 public:
  // T_{k-1,k} of frame `later` = k relative to the frame before it, or none when the two do
  // not register.
  using StepRegistration = std::function<std::optional<Eigen::Isometry3d>(int later)>;

  // `timestamps` of the frames, in order; neighbours further apart than max_step_s (a gap in
  // the sequence, a map's keyframes before the new frames) say nothing of each other's velocity.
  FrameVelocities(std::vector<double> timestamps, double max_step_s);

  // The velocity of `frame`, from the steps to its neighbours (registered through `step`
  // unless known), or none when neither registers.
  std::optional<CameraVelocity> Of(int frame, const StepRegistration& step);

  // Frames whose velocity came from both neighbours, from one, or from none.
  struct Counts {
    int both = 0;
    int one = 0;
    int none = 0;
  };
  const Counts& counts() const { return counts_; }
  // The angular rates (rad/s) of the frames with a velocity, in frame order.
  std::vector<double> AngularRates() const;

 private:
  // T_{k-1,k}, asked for through `step` the first time.
  const std::optional<Eigen::Isometry3d>& Step(int later, const StepRegistration& step);

  std::vector<double> timestamps_;
  double max_step_s_;
  std::map<int, std::optional<Eigen::Isometry3d>> steps_;  // by the later frame
  std::map<int, std::optional<CameraVelocity>> velocities_;
  Counts counts_;
};

// The rows of a rolling-shutter rig's range image, each exposed at its own time across the
// colour camera's readout (a registered depth image's rows with the colour image's), for a
// camera moving at `velocity` (the colour camera's): core/range_cloud.h's row motion.
RangeRowMotion RangeRowMotionOf(const Rig& rig, const CameraVelocity& velocity);

// The velocity at each of `stamps` (frame -> timestamp) that has a pose of `trajectory` (a
// run's every frame, in time order) within same_timestamp_s, from the poses next to that one
// there, as FrameVelocities estimates them from registrations; frames without one are left out.
std::map<int, CameraVelocity> VelocitiesAtStamps(const Trajectory& trajectory,
                                                 const std::map<int, double>& stamps,
                                                 double max_step_s, double same_timestamp_s);

}  // namespace ieslam
