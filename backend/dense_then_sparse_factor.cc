#include "backend/dense_then_sparse_factor.h"

#include <utility>

#include <glog/logging.h>

namespace ieslam {

DenseThenSparseFactor::DenseThenSparseFactor(int max_dense_pose_dim, Factory make_dense,
                                             Factory make_sparse)
    : max_dense_pose_dim_(max_dense_pose_dim), make_sparse_(std::move(make_sparse)) {
  dense_ = max_dense_pose_dim_ >= 6;
  active_ = dense_ ? make_dense() : make_sparse_();
  CHECK(active_ != nullptr);
}

void DenseThenSparseFactor::HandOverIfFull() {
  if (dense_ && 6 * (num_poses_ + 1) > max_dense_pose_dim_) HandOver();
}

void DenseThenSparseFactor::HandOver() {
  active_ = make_sparse_();
  CHECK(active_ != nullptr);
  dense_ = false;
}

FactorStatus DenseThenSparseFactor::AddAndSolve(const UpperColumnStorage& matrix,
                                                const InformationUpdate& update, bool keep_exact,
                                                const Eigen::VectorXd& info_vector,
                                                const Eigen::VectorXd& guess,
                                                Eigen::VectorXd* state) {
  HandOverIfFull();
  const bool exact = keep_exact || queried_;
  FactorStatus status = active_->AddAndSolve(matrix, update, exact, info_vector, guess, state);
  if (status == FactorStatus::kUnsolved) {
    HandOver();
    status = active_->AddAndSolve(matrix, update, exact, info_vector, guess, state);
    CHECK(status != FactorStatus::kUnsolved);
  }
  if (status == FactorStatus::kOk) {
    ++num_poses_;
    queried_ = false;
  }
  return status;
}

void DenseThenSparseFactor::AddDeferred(const UpperColumnStorage& matrix,
                                        const InformationUpdate& update) {
  HandOverIfFull();
  active_->AddDeferred(matrix, update);
  ++num_poses_;
}

void DenseThenSparseFactor::MakeExact() {
  active_->MakeExact();
  queried_ = true;
}

}  // namespace ieslam
