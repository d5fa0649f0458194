#include "backend/pose_covariance.h"

#include <utility>

#include <ceres/covariance.h>
#include <ceres/crs_matrix.h>
#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/SparseCore>

namespace ieslam {
namespace {

bool SparseQrTangentCovariances(ceres::Problem* problem,
                                const std::vector<PoseParameterBlocks>& poses, int num_threads,
                                std::map<int, Matrix6d>* tangent) {
  std::vector<std::pair<const double*, const double*>> blocks;
  for (const PoseParameterBlocks& pose : poses) {
    blocks.emplace_back(pose.t_w_c, pose.t_w_c);
    blocks.emplace_back(pose.t_w_c, pose.q_w_c);
    blocks.emplace_back(pose.q_w_c, pose.q_w_c);
  }
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::SPARSE_QR;
  covariance_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  covariance_options.num_threads = num_threads;
  ceres::Covariance covariance(covariance_options);
  if (!covariance.Compute(blocks, problem)) return false;
  for (const PoseParameterBlocks& pose : poses) {
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> P;
    const std::vector<const double*> pose_blocks = {pose.t_w_c, pose.q_w_c};
    CHECK(covariance.GetCovarianceMatrixInTangentSpace(pose_blocks, P.data()));
    (*tangent)[pose.frame_id] = P;
  }
  return true;
}

// H_ff's 3x3 diagonal blocks of the columns from `first` on (features touch no feature, so
// these are all of H_ff).
std::vector<Eigen::Matrix3d> FeatureBlocks(const Eigen::SparseMatrix<double>& H, int first) {
  std::vector<Eigen::Matrix3d> blocks((H.cols() - first) / 3, Eigen::Matrix3d::Zero());
  for (int c = first; c < H.cols(); ++c) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, c); it; ++it) {
      if (it.row() >= first && (it.row() - first) / 3 == (c - first) / 3) {
        blocks[(c - first) / 3]((it.row() - first) % 3, (c - first) % 3) = it.value();
      }
    }
  }
  return blocks;
}

// J (Ceres' Jacobian over the poses' then the features' tangent spaces) gives H = J^T J;
// S = H_pp - H_pf H_ff^-1 H_fp, and the poses' covariance is S^-1.
bool SchurTangentCovariances(ceres::Problem* problem, const std::vector<PoseParameterBlocks>& poses,
                             const std::vector<double*>& features, int num_threads,
                             std::map<int, Matrix6d>* tangent) {
  std::vector<double*> leading;
  for (const PoseParameterBlocks& pose : poses) {
    leading.push_back(pose.t_w_c);
    leading.push_back(pose.q_w_c);
  }
  Eigen::MatrixXd S;
  if (!LeadingSchurComplement(problem, leading, features, num_threads, &S)) return false;
  const int np = static_cast<int>(S.rows());
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd covariance = llt.solve(Eigen::MatrixXd::Identity(np, np));
  for (size_t k = 0; k < poses.size(); ++k) {
    (*tangent)[poses[k].frame_id] = covariance.block<6, 6>(6 * k, 6 * k);
  }
  return true;
}

}  // namespace

bool LeadingSchurComplement(ceres::Problem* problem, const std::vector<double*>& leading,
                            const std::vector<double*>& features, int num_threads,
                            Eigen::MatrixXd* S) {
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.parameter_blocks = leading;
  evaluate.parameter_blocks.insert(evaluate.parameter_blocks.end(), features.begin(),
                                   features.end());
  evaluate.num_threads = num_threads;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &crs)) return false;
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor, int>> J(
      crs.num_rows, crs.num_cols, static_cast<int>(crs.values.size()), crs.rows.data(),
      crs.cols.data(), crs.values.data());
  int np = 0;
  for (double* block : leading) np += problem->ParameterBlockTangentSize(block);
  const int nf = crs.num_cols - np;
  const Eigen::SparseMatrix<double> H = Eigen::SparseMatrix<double>(J.transpose()) * J;
  std::vector<Eigen::Triplet<double>> inverse_blocks;
  inverse_blocks.reserve(3 * nf);
  const std::vector<Eigen::Matrix3d> H_ff = FeatureBlocks(H, np);
  for (int f = 0; f < nf; f += 3) {
    const Eigen::LLT<Eigen::Matrix3d> llt(H_ff[f / 3]);
    if (llt.info() != Eigen::Success) return false;
    const Eigen::Matrix3d inverse = llt.solve(Eigen::Matrix3d::Identity());
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) inverse_blocks.emplace_back(f + r, f + c, inverse(r, c));
    }
  }
  Eigen::SparseMatrix<double> H_ff_inverse(nf, nf);
  H_ff_inverse.setFromTriplets(inverse_blocks.begin(), inverse_blocks.end());
  const Eigen::SparseMatrix<double> H_pf = H.topRightCorner(np, nf);
  *S = Eigen::MatrixXd(H.topLeftCorner(np, np)) -
       Eigen::MatrixXd(Eigen::SparseMatrix<double>(H_pf * H_ff_inverse) * H_pf.transpose());
  return true;
}

bool PoseTangentCovariances(ceres::Problem* problem, const std::vector<PoseParameterBlocks>& poses,
                            const std::vector<double*>& features, BaCovariance method,
                            int num_threads, std::map<int, Matrix6d>* tangent) {
  if (poses.empty()) return true;
  return method == BaCovariance::kSchur
             ? SchurTangentCovariances(problem, poses, features, num_threads, tangent)
             : SparseQrTangentCovariances(problem, poses, num_threads, tangent);
}

}  // namespace ieslam
