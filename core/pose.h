// Rigid poses in the paper's parameterisation and conversions to the usual ones.
//
// A pose is the 6-vector (x, y, z, alpha, beta, gamma) of Zhou et al. (2008), eq. 1:
// the translation followed by ZYX Euler angles, R = Rz(alpha) * Ry(beta) * Rx(gamma).
// Poses are camera-to-world (T_w_c): p_w = R * p_c + t.
//
// Near beta = +-90 deg (gimbal lock) alpha and gamma are not separately defined: only
// alpha - gamma (beta = +90) or alpha + gamma (beta = -90) is. RotationToEulerZyx then
// returns gamma = 0 and puts the whole rotation about the vertical axis into alpha,
// so that EulerZyxToRotation(RotationToEulerZyx(R)) == R still holds to rounding.
// Angles returned are wrapped to (-pi, pi], beta to [-pi/2, pi/2].
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ieslam {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Below this |cos(beta)| the Euler decomposition treats the rotation as gimbal-locked.
constexpr double kGimbalLockCosBeta = 1e-9;

// Wraps an angle to (-pi, pi].
double WrapAngle(double angle);

Eigen::Matrix3d EulerZyxToRotation(const Eigen::Vector3d& alpha_beta_gamma);
Eigen::Vector3d RotationToEulerZyx(const Eigen::Matrix3d& R);

Eigen::Quaterniond EulerZyxToQuaternion(const Eigen::Vector3d& alpha_beta_gamma);
Eigen::Vector3d QuaternionToEulerZyx(const Eigen::Quaterniond& q);

Eigen::Isometry3d PoseToIsometry(const Vector6d& pose);
Vector6d IsometryToPose(const Eigen::Isometry3d& T);

// T_a_c = T_a_b * T_b_c.
Vector6d ComposePoses(const Vector6d& T_a_b, const Vector6d& T_b_c);
// T_b_a from T_a_b.
Vector6d InversePose(const Vector6d& T_a_b);
// The pose of frame b in frame a, both given in the world: T_a_b = T_w_a^-1 * T_w_b.
Vector6d RelativePose(const Vector6d& T_w_a, const Vector6d& T_w_b);

// The difference of two poses with angle components wrapped to (-pi, pi]: the error
// measure used for +-2 sigma plots and NEES on the Euler parameterisation.
Vector6d PoseDifference(const Vector6d& a, const Vector6d& b);

// Rotation angle (radians) of R_a^T R_b, robust near 0 and pi.
double RotationAngleBetween(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b);

}  // namespace ieslam
