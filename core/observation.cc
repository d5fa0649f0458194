#include "core/observation.h"

namespace ieslam {

Eigen::Matrix3d ObservationCovariance(double pixel_sigma, const RangeNoiseModel& noise,
                                      double range_m) {
  const double sigma_d = noise.Sigma(range_m);
  return Eigen::Vector3d(pixel_sigma * pixel_sigma, pixel_sigma * pixel_sigma, sigma_d * sigma_d)
      .asDiagonal();
}

Eigen::Vector3d WorldToCamera(const Vector6d& T_w_c, const Eigen::Vector3d& p_w) {
  return EulerZyxToRotation(T_w_c.tail<3>()).transpose() * (p_w - T_w_c.head<3>());
}

std::array<Eigen::Matrix3d, 3> EulerZyxRotationDerivatives(
    const Eigen::Vector3d& alpha_beta_gamma) {
  const Eigen::Matrix3d Rz =
      Eigen::AngleAxisd(alpha_beta_gamma[0], Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d Ry =
      Eigen::AngleAxisd(alpha_beta_gamma[1], Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d Rx =
      Eigen::AngleAxisd(alpha_beta_gamma[2], Eigen::Vector3d::UnitX()).toRotationMatrix();
  // d/dtheta Rk(theta) = [e_k]x Rk(theta) for a rotation about a fixed axis e_k.
  const auto hat = [](const Eigen::Vector3d& w) {
    Eigen::Matrix3d W;
    W << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
    return W;
  };
  return {hat(Eigen::Vector3d::UnitZ()) * Rz * Ry * Rx,
          Rz * hat(Eigen::Vector3d::UnitY()) * Ry * Rx,
          Rz * Ry * hat(Eigen::Vector3d::UnitX()) * Rx};
}

Eigen::Vector3d PredictObservation(const Vector6d& T_w_c, const Eigen::Vector3d& p_w,
                                   const PinholeCamera& camera, Matrix36d* d_z_d_pose,
                                   Eigen::Matrix3d* d_z_d_point) {
  const Eigen::Matrix3d R = EulerZyxToRotation(T_w_c.tail<3>());
  const Eigen::Vector3d delta = p_w - T_w_c.head<3>();
  const Eigen::Vector3d p_c = R.transpose() * delta;
  const double inv_z = 1.0 / p_c.z();
  const double range = p_c.norm();
  const Eigen::Vector3d z(camera.fx * p_c.x() * inv_z + camera.cx,
                          camera.fy * p_c.y() * inv_z + camera.cy, range);
  if (d_z_d_pose == nullptr && d_z_d_point == nullptr) return z;

  // Chain rule through p_L: dz/dp_L (projection and range) times dp_L/d(pose, point).
  Eigen::Matrix3d d_z_d_pc;
  d_z_d_pc << camera.fx * inv_z, 0.0, -camera.fx * p_c.x() * inv_z * inv_z,  //
      0.0, camera.fy * inv_z, -camera.fy * p_c.y() * inv_z * inv_z,          //
      p_c.transpose() / range;
  // dp_L/dp_w = R^T, dp_L/dt = -R^T.
  const Eigen::Matrix3d d_z_d_pw = d_z_d_pc * R.transpose();
  if (d_z_d_point != nullptr) *d_z_d_point = d_z_d_pw;
  if (d_z_d_pose != nullptr) {
    d_z_d_pose->leftCols<3>() = -d_z_d_pw;
    const std::array<Eigen::Matrix3d, 3> dR = EulerZyxRotationDerivatives(T_w_c.tail<3>());
    for (int k = 0; k < 3; ++k) {
      d_z_d_pose->col(3 + k) = d_z_d_pc * (dR[k].transpose() * delta);
    }
  }
  return z;
}

Eigen::Matrix3d BackProjectedCovariance(const Eigen::Vector3d& p_c, const Eigen::Matrix3d& Q,
                                        const PinholeCamera& camera) {
  Eigen::Matrix3d d_z_d_pc;
  PredictObservation(Vector6d::Zero(), p_c, camera, nullptr, &d_z_d_pc);
  const Eigen::Matrix3d d_pc_d_z = d_z_d_pc.inverse();
  return d_pc_d_z * Q * d_pc_d_z.transpose();
}

Eigen::Vector3d ObservationToWorld(const Vector6d& T_w_c, const Eigen::Vector3d& z,
                                   const PinholeCamera& camera) {
  const Eigen::Vector3d ray((z.x() - camera.cx) / camera.fx, (z.y() - camera.cy) / camera.fy, 1.0);
  const Eigen::Vector3d p_c = ray.normalized() * z.z();
  return EulerZyxToRotation(T_w_c.tail<3>()) * p_c + T_w_c.head<3>();
}

}  // namespace ieslam
