// The paper's observation of a 3-D point feature from a camera pose (eqs. 4-8):
//   p_L = R(alpha, beta, gamma)^T (p_F - p_C)                    (H2)
//   z = (u, v, d) = (fx x_L/z_L + cx, fy y_L/z_L + cy, |p_L|)    (H1)
// with (u, v) the undistorted pixel and d the range along the ray. Keypoints are
// undistorted before they become observations, so the model uses only fx, fy, cx, cy.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/pose.h"

namespace ieslam {

using Matrix36d = Eigen::Matrix<double, 3, 6>;

// One measurement z = (u, v, d) of feature `feature_id` with its noise covariance Q.
struct FeatureObservation {
  int64_t feature_id = -1;
  Eigen::Vector3d z = Eigen::Vector3d::Zero();
  Eigen::Matrix3d Q = Eigen::Matrix3d::Identity();
};

// Q for a measurement at range d: pixel noise on u and v, the range imager's sigma_d(d).
Eigen::Matrix3d ObservationCovariance(double pixel_sigma, const RangeNoiseModel& noise,
                                      double range_m);

// dR/dalpha, dR/dbeta, dR/dgamma of R = Rz(alpha) Ry(beta) Rx(gamma). Each factor is
// differentiated in place, so the result is exact at gimbal lock too (beta = +-90 deg),
// where only the Euler parameterisation, not its derivative, loses rank.
std::array<Eigen::Matrix3d, 3> EulerZyxRotationDerivatives(const Eigen::Vector3d& alpha_beta_gamma);

// The point in the camera frame, p_L = R^T (p_w - t).
Eigen::Vector3d WorldToCamera(const Vector6d& T_w_c, const Eigen::Vector3d& p_w);

// z = H(pose, feature) and, optionally, its Jacobians with respect to the pose 6-vector
// (x, y, z, alpha, beta, gamma) and to the feature's world position. The Jacobians are
// analytic; the caller keeps p_L.z > 0 (a point behind or on the camera plane has none).
Eigen::Vector3d PredictObservation(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                                   const PinholeCamera& camera, Matrix36d* d_z_d_pose = nullptr,
                                   Eigen::Matrix3d* d_z_d_point = nullptr);

// Covariance of the camera-frame point p_c that a measurement z = H(p_c) with covariance Q
// back-projects to: J Q J^T, J = dp_c/dz the inverse of H's Jacobian at p_c (first order).
// Along the ray it is sigma_d^2; across it the pixel noise scaled by the depth.
Eigen::Matrix3d BackProjectedCovariance(const Eigen::Vector3d& p_c, const Eigen::Matrix3d& Q,
                                        const PinholeCamera& camera);

// Inverse of H for a known pose: the world point that produced z.
Eigen::Vector3d ObservationToWorld(const Vector6d& T_w_c, const Eigen::Vector3d& z,
                                   const PinholeCamera& camera);

}  // namespace ieslam
