// The bundle adjustment's residual: the filter's (u, v, d) observation (Zhou et al. 2008,
// eqs. 4-8; core/observation.h) of a world point from a camera pose, whitened by its noise Q.
//
// The pose is held as a unit quaternion q_w_c (Eigen's x, y, z, w storage, the layout
// ceres::EigenQuaternionManifold expects) and a translation t_w_c, camera-to-world, so that
// the optimiser never meets the Euler singularity the filter's 6-vector has at beta = +-90 deg.
// Both residuals' Jacobians are in closed form; tests/backend/bundle_adjustment_test.cc
// checks them with ceres::GradientChecker and against ceres::AutoDiffCostFunction of the
// templated operator().
#pragma once

#include <cmath>
#include <string>

#include <ceres/rotation.h>
#include <ceres/sized_cost_function.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera.h"
#include "core/pose.h"

namespace ieslam {

// Upper-triangular W with W^T W = Q^-1, i.e. W = L^T for the Cholesky factor L L^T = Q^-1:
// the residual W (h(x) - z) then has identity covariance and the cost 1/2 |W e|^2 is the
// filter's 1/2 e^T Q^-1 e. Returns false when Q is not symmetric positive definite.
inline bool SqrtInformation(const Eigen::Matrix3d& Q, Eigen::Matrix3d* W) {
  if (!Q.allFinite() || !Q.isApprox(Q.transpose(), 1e-9)) return false;
  const Eigen::LLT<Eigen::Matrix3d> llt_q(Q);
  if (llt_q.info() != Eigen::Success) return false;
  const Eigen::Matrix3d information = llt_q.solve(Eigen::Matrix3d::Identity());
  const Eigen::LLT<Eigen::Matrix3d> llt(0.5 * (information + information.transpose()));
  if (llt.info() != Eigen::Success) return false;
  *W = llt.matrixU();
  return W->allFinite();
}

namespace ba_internal {

// [v]x: Skew(v) a = v x a.
inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// d theta / d q (3 x 4, Eigen's x, y, z, w order): to first order R(q' / |q'|) =
// Exp(theta) R(q / |q|) for q' = q + dq, theta in the world frame. With q^ = q / |q| =
// (u, w): theta = 2 (w du - u dw + u x du) for a step dq^ on the sphere, and
// dq^ = (I - q^ q^^T) dq / |q|.
inline Eigen::Matrix<double, 3, 4> WorldRotationOfQuaternionStep(const double* q_ptr) {
  const Eigen::Map<const Eigen::Vector4d> q(q_ptr);
  const double norm = q.norm();
  const Eigen::Vector4d q_unit = q / norm;
  const Eigen::Vector3d u = q_unit.head<3>();
  Eigen::Matrix<double, 3, 4> d_theta_d_q_unit;
  d_theta_d_q_unit.leftCols<3>() = 2.0 * (q_unit[3] * Eigen::Matrix3d::Identity() + Skew(u));
  d_theta_d_q_unit.col(3) = -2.0 * u;
  return d_theta_d_q_unit * ((Eigen::Matrix4d::Identity() - q_unit * q_unit.transpose()) / norm);
}

// The inverse of SO(3)'s left Jacobian at phi: Log(Exp(a) Exp(phi)) = phi + J_l(phi)^-1 a to
// first order in a.
inline Eigen::Matrix3d InverseLeftJacobian(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  const Eigen::Matrix3d K = Skew(phi);
  // 1 / a^2 - (1 + cos a) / (2 a sin a), by its series below 1e-4 rad (1/12 + a^2 / 720).
  const double c = angle < 1e-4 ? 1.0 / 12.0 + angle * angle / 720.0
                                : 1.0 / (angle * angle) -
                                      (1.0 + std::cos(angle)) / (2.0 * angle * std::sin(angle));
  return Eigen::Matrix3d::Identity() - 0.5 * K + c * K * K;
}

}  // namespace ba_internal

// r = W (h(q_w_c, t_w_c, p_w) - z), with h = (fx x/z + cx, fy y/z + cy, |p_c|) and
// p_c = R(q_w_c)^T (p_w - t_w_c).
class UvdResidual {
 public:
  UvdResidual(const PinholeCamera& camera, const Eigen::Vector3d& z,
              const Eigen::Matrix3d& sqrt_information, double min_depth_m)
      : fx_(camera.fx),
        fy_(camera.fy),
        cx_(camera.cx),
        cy_(camera.cy),
        z_(z),
        W_(sqrt_information),
        min_depth_m_(min_depth_m) {}

  template <typename T>
  bool operator()(const T* q_w_c_ptr, const T* t_w_c_ptr, const T* p_w_ptr, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_w_c(q_w_c_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_w_c(t_w_c_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_w(p_w_ptr);
    // The rotation matrix rather than q * v: Eigen's quaternion-vector product assumes a
    // unit norm, and the gradient checker's finite differences step off the unit sphere.
    const Eigen::Matrix<T, 3, 3> R_w_c = q_w_c.normalized().toRotationMatrix();
    const Eigen::Matrix<T, 3, 1> p_c = R_w_c.transpose() * (p_w - t_w_c);
    // Behind or on the camera plane the model has no derivative: the step is rejected.
    if (!(p_c[2] > T(min_depth_m_))) return false;
    Eigen::Matrix<T, 3, 1> error;
    error[0] = T(fx_) * p_c[0] / p_c[2] + T(cx_) - T(z_[0]);
    error[1] = T(fy_) * p_c[1] / p_c[2] + T(cy_) - T(z_[1]);
    error[2] = p_c.norm() - T(z_[2]);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = W_.cast<T>() * error;
    return true;
  }

  // The residual, through operator() (so that it has the same bits whether or not Ceres asks
  // for Jacobians), and where the pointers are not null its Jacobians (row-major 3x4, 3x3,
  // 3x3) in closed form: what automatic differentiation of operator()
  // gives, to rounding, for a fraction of the cost (evaluating them was the largest part of
  // the bundle adjustment's time). With q^ = q / |q| and d = p_w - t_w_c,
  // p_c = R(q^)^T d = (w^2 - u.u) d + 2 u (u.d) - 2 w (u x d) for q^ = (u, w), so
  // d p_c / d u = 2 ((u.d) I + u d^T - d u^T + w [d]x) and d p_c / d w = 2 (w d - u x d),
  // times d q^ / d q = (I - q^ q^^T) / |q|.
  bool Evaluate(const double* q_w_c, const double* t_w_c, const double* p_w, double* residual,
                double* d_q, double* d_t, double* d_p) const {
    if (!(*this)(q_w_c, t_w_c, p_w, residual)) return false;
    if (d_q == nullptr && d_t == nullptr && d_p == nullptr) return true;
    const Eigen::Map<const Eigen::Vector4d> q(q_w_c);
    const double norm = q.norm();
    const Eigen::Vector4d q_unit = q / norm;
    const Eigen::Vector3d u = q_unit.head<3>();
    const double w = q_unit[3];
    const Eigen::Matrix3d R_c_w = Eigen::Quaterniond(q_unit[3], q_unit[0], q_unit[1], q_unit[2])
                                      .toRotationMatrix()
                                      .transpose();
    const Eigen::Vector3d d =
        Eigen::Map<const Eigen::Vector3d>(p_w) - Eigen::Map<const Eigen::Vector3d>(t_w_c);
    const Eigen::Vector3d p_c = R_c_w * d;
    const double inv_z = 1.0 / p_c.z(), range = p_c.norm();
    Eigen::Matrix3d d_error_d_p_c;
    d_error_d_p_c << fx_ * inv_z, 0.0, -fx_ * p_c.x() * inv_z * inv_z,  //
        0.0, fy_ * inv_z, -fy_ * p_c.y() * inv_z * inv_z,               //
        p_c.transpose() / range;
    const Eigen::Matrix3d A = W_ * d_error_d_p_c;
    using RowMajor33Map = Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;
    if (d_p != nullptr) RowMajor33Map{d_p} = A * R_c_w;
    if (d_t != nullptr) RowMajor33Map{d_t} = -A * R_c_w;
    if (d_q != nullptr) {
      Eigen::Matrix<double, 3, 4> d_p_c_d_q_unit;
      d_p_c_d_q_unit.leftCols<3>() =
          2.0 * (u.dot(d) * Eigen::Matrix3d::Identity() + u * d.transpose() - d * u.transpose() +
                 w * ba_internal::Skew(d));
      d_p_c_d_q_unit.col(3) = 2.0 * (w * d - u.cross(d));
      const Eigen::Matrix4d normalize =
          (Eigen::Matrix4d::Identity() - q_unit * q_unit.transpose()) / norm;
      Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>>{d_q} =
          A * d_p_c_d_q_unit * normalize;
    }
    return true;
  }

  // Parameter blocks: q_w_c (4), t_w_c (3), p_w (3).
  static ceres::CostFunction* Create(const PinholeCamera& camera, const Eigen::Vector3d& z,
                                     const Eigen::Matrix3d& sqrt_information, double min_depth_m);

 private:
  double fx_, fy_, cx_, cy_;
  Eigen::Vector3d z_;
  Eigen::Matrix3d W_;
  double min_depth_m_;
};

// UvdResidual's cost function for Ceres, with its closed-form Jacobians.
class UvdCostFunction final : public ceres::SizedCostFunction<3, 4, 3, 3> {
 public:
  explicit UvdCostFunction(const UvdResidual& residual) : residual_(residual) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return residual_.Evaluate(parameters[0], parameters[1], parameters[2], residuals,
                              jacobians != nullptr ? jacobians[0] : nullptr,
                              jacobians != nullptr ? jacobians[1] : nullptr,
                              jacobians != nullptr ? jacobians[2] : nullptr);
  }

 private:
  UvdResidual residual_;
};

inline ceres::CostFunction* UvdResidual::Create(const PinholeCamera& camera,
                                                const Eigen::Vector3d& z,
                                                const Eigen::Matrix3d& sqrt_information,
                                                double min_depth_m) {
  return new UvdCostFunction(UvdResidual(camera, z, sqrt_information, min_depth_m));
}

// r = S (Log(R_E), t_E) for E = Y T_sj_si^-1 and Y = (T_w_cj T_c_s)^-1 T_w_ci T_c_s, the
// residual of a RelativePoseConstraint (backend/bundle_adjustment.h): zero where the poses
// agree with the measured relative pose, and (omega, v) where they differ from it by
// Y = [Exp(omega), v] T_sj_si, the chart the measurement's information S^T S is given in.
class RelativePoseResidual {
 public:
  RelativePoseResidual(const Eigen::Isometry3d& T_sj_si, const Eigen::Isometry3d& T_c_s,
                       const Matrix6d& sqrt_information)
      : R_hat_(T_sj_si.linear()),
        t_hat_(T_sj_si.translation()),
        R_c_s_(T_c_s.linear()),
        t_c_s_(T_c_s.translation()),
        S_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* q_w_ci_ptr, const T* t_w_ci_ptr, const T* q_w_cj_ptr,
                  const T* t_w_cj_ptr, T* residual) const {
    using Matrix3 = Eigen::Matrix<T, 3, 3>;
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    const Matrix3 R_c_s = R_c_s_.cast<T>();
    const Vector3 t_c_s = t_c_s_.cast<T>();
    // The sensors' poses T_w_s = T_w_c T_c_s (rotation matrices: see UvdResidual).
    const Matrix3 R_w_ci =
        Eigen::Map<const Eigen::Quaternion<T>>(q_w_ci_ptr).normalized().toRotationMatrix();
    const Matrix3 R_w_cj =
        Eigen::Map<const Eigen::Quaternion<T>>(q_w_cj_ptr).normalized().toRotationMatrix();
    const Matrix3 R_w_si = R_w_ci * R_c_s;
    const Matrix3 R_w_sj = R_w_cj * R_c_s;
    const Vector3 t_w_si = R_w_ci * t_c_s + Eigen::Map<const Vector3>(t_w_ci_ptr);
    const Vector3 t_w_sj = R_w_cj * t_c_s + Eigen::Map<const Vector3>(t_w_cj_ptr);
    const Matrix3 R_y = R_w_sj.transpose() * R_w_si;
    const Vector3 t_y = R_w_sj.transpose() * (t_w_si - t_w_sj);
    const Matrix3 R_e = R_y * R_hat_.transpose().cast<T>();
    Eigen::Matrix<T, 6, 1> error;
    ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(R_e.data()), error.data());
    error.template tail<3>() = t_y - R_e * t_hat_.cast<T>();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = S_.cast<T>() * error;
    return true;
  }

  // The residual, as operator(), and where the pointers are not null its Jacobians
  // (row-major 6x4, 6x3, 6x4, 6x3) in closed form. A world-frame rotation theta of camera i
  // turns R_y into Exp(R_w_sj^T theta) R_y, of camera j into Exp(-R_w_sj^T theta) R_y;
  // Log(R_E) then moves by J_l(Log R_E)^-1 times that, and t_E = t_y - R_E t^ by the
  // rotation of R_E t^ and the lever arms of the sensors' offsets.
  bool Evaluate(const double* q_w_ci, const double* t_w_ci, const double* q_w_cj,
                const double* t_w_cj, double* residual, double* d_q_i, double* d_t_i, double* d_q_j,
                double* d_t_j) const {
    using ba_internal::Skew;
    if (!(*this)(q_w_ci, t_w_ci, q_w_cj, t_w_cj, residual)) return false;
    if (d_q_i == nullptr && d_t_i == nullptr && d_q_j == nullptr && d_t_j == nullptr) {
      return true;
    }
    const auto rotation = [](const double* q) {
      return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
    };
    const Eigen::Matrix3d R_w_ci = rotation(q_w_ci), R_w_cj = rotation(q_w_cj);
    const Eigen::Vector3d arm_i = R_w_ci * t_c_s_;
    const Eigen::Vector3d t_w_si = arm_i + Eigen::Map<const Eigen::Vector3d>(t_w_ci);
    const Eigen::Matrix3d R_sj_w = (R_w_cj * R_c_s_).transpose();
    const Eigen::Matrix3d R_e = R_sj_w * R_w_ci * R_c_s_ * R_hat_.transpose();
    const Eigen::AngleAxisd angle_axis(R_e);
    const Eigen::Vector3d phi = angle_axis.angle() * angle_axis.axis();
    const Eigen::Matrix3d rotation_part = ba_internal::InverseLeftJacobian(phi) * R_sj_w;
    const Eigen::Matrix3d turn = Skew(R_e * t_hat_) * R_sj_w;
    Eigen::Matrix<double, 6, 3> d_e_d_theta_i, d_e_d_theta_j, d_e_d_t_i, d_e_d_t_j;
    d_e_d_theta_i << rotation_part, turn - R_sj_w * Skew(arm_i);
    d_e_d_theta_j << -rotation_part,
        R_sj_w * Skew(t_w_si - Eigen::Map<const Eigen::Vector3d>(t_w_cj)) - turn;
    d_e_d_t_i << Eigen::Matrix3d::Zero(), R_sj_w;
    d_e_d_t_j << Eigen::Matrix3d::Zero(), -R_sj_w;
    using RowMajor64 = Eigen::Matrix<double, 6, 4, Eigen::RowMajor>;
    using RowMajor63 = Eigen::Matrix<double, 6, 3, Eigen::RowMajor>;
    if (d_q_i != nullptr) {
      Eigen::Map<RowMajor64>{d_q_i} =
          S_ * d_e_d_theta_i * ba_internal::WorldRotationOfQuaternionStep(q_w_ci);
    }
    if (d_q_j != nullptr) {
      Eigen::Map<RowMajor64>{d_q_j} =
          S_ * d_e_d_theta_j * ba_internal::WorldRotationOfQuaternionStep(q_w_cj);
    }
    if (d_t_i != nullptr) Eigen::Map<RowMajor63>{d_t_i} = S_ * d_e_d_t_i;
    if (d_t_j != nullptr) Eigen::Map<RowMajor63>{d_t_j} = S_ * d_e_d_t_j;
    return true;
  }

  // Parameter blocks: q_w_ci (4), t_w_ci (3), q_w_cj (4), t_w_cj (3).
  static ceres::CostFunction* Create(const Eigen::Isometry3d& T_sj_si,
                                     const Eigen::Isometry3d& T_c_s,
                                     const Matrix6d& sqrt_information);

 private:
  Eigen::Matrix3d R_hat_;
  Eigen::Vector3d t_hat_;
  Eigen::Matrix3d R_c_s_;
  Eigen::Vector3d t_c_s_;
  Matrix6d S_;
};

// RelativePoseResidual's cost function for Ceres, with its closed-form Jacobians.
class RelativePoseCostFunction final : public ceres::SizedCostFunction<6, 4, 3, 4, 3> {
 public:
  explicit RelativePoseCostFunction(const RelativePoseResidual& residual) : residual_(residual) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const auto block = [jacobians](int k) { return jacobians != nullptr ? jacobians[k] : nullptr; };
    return residual_.Evaluate(parameters[0], parameters[1], parameters[2], parameters[3], residuals,
                              block(0), block(1), block(2), block(3));
  }

 private:
  RelativePoseResidual residual_;
};

inline ceres::CostFunction* RelativePoseResidual::Create(const Eigen::Isometry3d& T_sj_si,
                                                         const Eigen::Isometry3d& T_c_s,
                                                         const Matrix6d& sqrt_information) {
  return new RelativePoseCostFunction(RelativePoseResidual(T_sj_si, T_c_s, sqrt_information));
}

}  // namespace ieslam
