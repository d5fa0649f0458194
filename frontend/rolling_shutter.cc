#include "frontend/rolling_shutter.h"

#include <algorithm>
#include <utility>

#include <glog/logging.h>

#include "core/timestamp_association.h"

namespace ieslam {

CameraVelocity VelocityBetween(const Eigen::Isometry3d& T_a_b, double dt) {
  CHECK_GT(dt, 0.0);
  const Eigen::AngleAxisd rotation(T_a_b.linear());
  CameraVelocity velocity;
  velocity.angular_rad_s = rotation.axis() * (rotation.angle() / dt);
  velocity.linear_m_s = T_a_b.translation() / dt;
  return velocity;
}

std::optional<CameraVelocity> VelocityOfFrame(const std::optional<Eigen::Isometry3d>& T_prev_frame,
                                              double dt_before,
                                              const std::optional<Eigen::Isometry3d>& T_frame_next,
                                              double dt_after) {
  std::optional<CameraVelocity> before, after;
  if (T_prev_frame) before = VelocityBetween(*T_prev_frame, dt_before);
  if (T_frame_next) after = VelocityBetween(*T_frame_next, dt_after);
  if (before && after) {
    // Both are in nearly the same frame (the camera turns a degree or two per step), so their
    // mean is the velocity at the frame to first order in that rotation.
    CameraVelocity mean;
    mean.angular_rad_s = 0.5 * (before->angular_rad_s + after->angular_rad_s);
    mean.linear_m_s = 0.5 * (before->linear_m_s + after->linear_m_s);
    return mean;
  }
  return before ? before : after;
}

Eigen::Isometry3d MotionOver(const CameraVelocity& velocity, double tau) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d rotation = velocity.angular_rad_s * tau;
  const double angle = rotation.norm();
  if (angle > 0.0) T.linear() = Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix();
  T.translation() = velocity.linear_m_s * tau;
  return T;
}

LiftedPoint CompensateRollingShutter(const LiftedPoint& point, double row,
                                     const CameraVelocity& velocity, const Rig& rig) {
  if (!point.valid) return point;
  const Eigen::Vector3d p_c = MotionOver(velocity, rig.RowTimeOffset(row)) * point.p_c;
  // A point that the motion carries behind the camera is no measurement of this model.
  if (!(p_c.z() > 0.0)) return LiftedPoint();
  return LiftedPointAt(p_c, rig);
}

FrameVelocities::FrameVelocities(std::vector<double> timestamps, double max_step_s)
    : timestamps_(std::move(timestamps)), max_step_s_(max_step_s) {}

const std::optional<Eigen::Isometry3d>& FrameVelocities::Step(int later,
                                                              const StepRegistration& step) {
  auto it = steps_.find(later);
  if (it == steps_.end()) {
    const double dt = timestamps_[later] - timestamps_[later - 1];
    std::optional<Eigen::Isometry3d> T;
    if (dt > 0.0 && dt <= max_step_s_) T = step(later);
    it = steps_.emplace(later, T).first;
  }
  return it->second;
}

std::optional<CameraVelocity> FrameVelocities::Of(int frame, const StepRegistration& step) {
  CHECK(frame >= 0 && frame < static_cast<int>(timestamps_.size()));
  const auto known = velocities_.find(frame);
  if (known != velocities_.end()) return known->second;
  const int last = static_cast<int>(timestamps_.size()) - 1;
  const std::optional<Eigen::Isometry3d> none;
  const auto& before = frame > 0 ? Step(frame, step) : none;
  const auto& after = frame < last ? Step(frame + 1, step) : none;
  const double dt_before = frame > 0 ? timestamps_[frame] - timestamps_[frame - 1] : 0.0;
  const double dt_after = frame < last ? timestamps_[frame + 1] - timestamps_[frame] : 0.0;
  const std::optional<CameraVelocity> velocity =
      VelocityOfFrame(before, dt_before, after, dt_after);
  ++(before && after ? counts_.both : velocity ? counts_.one : counts_.none);
  return velocities_.emplace(frame, velocity).first->second;
}

std::vector<double> FrameVelocities::AngularRates() const {
  std::vector<double> rates;
  for (const auto& [frame, velocity] : velocities_) {
    if (velocity) rates.push_back(velocity->angular_rad_s.norm());
  }
  return rates;
}

RangeRowMotion RangeRowMotionOf(const Rig& rig, const CameraVelocity& velocity) {
  const Eigen::Isometry3d T_colour_range = rig.T_colour_range;
  const double readout_s = rig.colour_readout_s;
  const int rows = rig.range.camera.height;
  return [T_colour_range, readout_s, rows, velocity](double row) {
    const double tau = ((row + 0.5) / rows - 0.5) * readout_s;
    return Eigen::Isometry3d(T_colour_range.inverse() * MotionOver(velocity, tau) * T_colour_range);
  };
}

std::map<int, CameraVelocity> VelocitiesAtStamps(const Trajectory& trajectory,
                                                 const std::map<int, double>& stamps,
                                                 double max_step_s, double same_timestamp_s) {
  std::vector<double> times;
  for (const TimedPose& pose : trajectory) times.push_back(pose.timestamp);
  std::vector<std::pair<double, int>> by_time;  // AssociateStamps wants both lists sorted
  for (const auto& [frame, stamp] : stamps) by_time.emplace_back(stamp, frame);
  std::sort(by_time.begin(), by_time.end());
  std::vector<double> wanted;
  for (const auto& [stamp, frame] : by_time) wanted.push_back(stamp);
  FrameVelocities velocities(times, max_step_s);
  const auto step = [&trajectory](int later) -> std::optional<Eigen::Isometry3d> {
    return trajectory[later - 1].T_w_c.inverse() * trajectory[later].T_w_c;
  };
  std::map<int, CameraVelocity> at;
  for (const StampMatch& m : AssociateStamps(wanted, times, 0.0, same_timestamp_s)) {
    const std::optional<CameraVelocity> velocity =
        velocities.Of(static_cast<int>(m.second_index), step);
    if (velocity) at.emplace(by_time[m.first_index].second, *velocity);
  }
  return at;
}

}  // namespace ieslam
