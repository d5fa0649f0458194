// The marginal covariances of a solved ceres::Problem's poses, over the tangent spaces Ceres
// solves in: 6x6 per pose, its translation block first, then its quaternion block's
// EigenQuaternionManifold 3-vector.
#pragma once

#include <map>
#include <vector>

#include <ceres/problem.h>
#include <Eigen/Core>

#include "core/pose.h"

namespace ieslam {

// kSchur: each feature's 3x3 block of J^T J eliminated on its own (a feature touches no other
// feature) and the poses' Schur complement factored densely; kSparseQr: ceres::Covariance,
// the sparse QR of the whole Jacobian, exact too and the reference the tests hold kSchur to,
// but minutes where kSchur takes a fraction of a second on a few hundred keyframes.
enum class BaCovariance { kSchur, kSparseQr };

// A pose's two parameter blocks in the problem.
struct PoseParameterBlocks {
  int frame_id = 0;
  double* t_w_c = nullptr;
  double* q_w_c = nullptr;
};

// The covariances of `poses` by `method`, from the Jacobian at the problem's current values
// with the loss applied (as ceres::Covariance uses it). Every other parameter block of the
// problem (the anchor) is held fixed; `features` lists the feature blocks that carry
// residuals (kSchur needs them; kSparseQr finds them itself). False when the information
// matrix is singular: a pose or feature the residuals do not determine.
// The Schur complement S = H_ll - H_lf H_ff^-1 H_fl of H = J^T J, J the problem's Jacobian at
// its current values over the tangent spaces of `leading` (in that order) and then
// `features` (3-vectors, each touching no other feature: H_ff is block diagonal), every other
// block held fixed. S^-1 is the leading blocks' marginal covariance. False when the Jacobian
// cannot be evaluated or a feature's block is singular.
bool LeadingSchurComplement(ceres::Problem* problem, const std::vector<double*>& leading,
                            const std::vector<double*>& features, int num_threads,
                            Eigen::MatrixXd* S);

bool PoseTangentCovariances(ceres::Problem* problem, const std::vector<PoseParameterBlocks>& poses,
                            const std::vector<double*>& features, BaCovariance method,
                            int num_threads, std::map<int, Matrix6d>* tangent);

}  // namespace ieslam
