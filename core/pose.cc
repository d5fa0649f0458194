#include "core/pose.h"

#include <cmath>

namespace ieslam {

double WrapAngle(double angle) {
  double wrapped = std::remainder(angle, 2.0 * M_PI);  // in [-pi, pi]
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

Eigen::Matrix3d EulerZyxToRotation(const Eigen::Vector3d& alpha_beta_gamma) {
  return (Eigen::AngleAxisd(alpha_beta_gamma[0], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(alpha_beta_gamma[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(alpha_beta_gamma[2], Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d RotationToEulerZyx(const Eigen::Matrix3d& R) {
  // R = Rz(a) Ry(b) Rx(g): R(2,0) = -sin b, R(1,0)/R(0,0) = tan a, R(2,1)/R(2,2) = tan g.
  const double cos_beta = std::hypot(R(0, 0), R(1, 0));
  const double beta = std::atan2(-R(2, 0), cos_beta);
  if (cos_beta > kGimbalLockCosBeta) {
    return {WrapAngle(std::atan2(R(1, 0), R(0, 0))), beta, WrapAngle(std::atan2(R(2, 1), R(2, 2)))};
  }
  // Gimbal lock: with gamma = 0, R(0,1) = -sin a and R(1,1) = cos a for either sign of beta.
  return {WrapAngle(std::atan2(-R(0, 1), R(1, 1))), beta, 0.0};
}

Eigen::Quaterniond EulerZyxToQuaternion(const Eigen::Vector3d& alpha_beta_gamma) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(alpha_beta_gamma[0], Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(alpha_beta_gamma[1], Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(alpha_beta_gamma[2], Eigen::Vector3d::UnitX()));
}

Eigen::Vector3d QuaternionToEulerZyx(const Eigen::Quaterniond& q) {
  return RotationToEulerZyx(q.normalized().toRotationMatrix());
}

Eigen::Isometry3d PoseToIsometry(const Vector6d& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = EulerZyxToRotation(pose.tail<3>());
  T.translation() = pose.head<3>();
  return T;
}

Vector6d IsometryToPose(const Eigen::Isometry3d& T) {
  Vector6d pose;
  pose << T.translation(), RotationToEulerZyx(T.linear());
  return pose;
}

Vector6d ComposePoses(const Vector6d& T_a_b, const Vector6d& T_b_c) {
  return IsometryToPose(PoseToIsometry(T_a_b) * PoseToIsometry(T_b_c));
}

Vector6d InversePose(const Vector6d& T_a_b) {
  return IsometryToPose(PoseToIsometry(T_a_b).inverse());
}

Vector6d RelativePose(const Vector6d& T_w_a, const Vector6d& T_w_b) {
  return IsometryToPose(PoseToIsometry(T_w_a).inverse() * PoseToIsometry(T_w_b));
}

Vector6d PoseDifference(const Vector6d& a, const Vector6d& b) {
  Vector6d diff = a - b;
  for (int i = 3; i < 6; ++i) diff[i] = WrapAngle(diff[i]);
  return diff;
}

double RotationAngleBetween(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b) {
  return Eigen::AngleAxisd(R_a.transpose() * R_b).angle();
}

}  // namespace ieslam
