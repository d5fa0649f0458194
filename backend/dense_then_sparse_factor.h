// The information filter's factorisation policy: the dense pose Schur complement while the
// poses are few, then the sparse factor for good.
//
// The dense factor (backend/pose_schur_information_factor.h) is faster while the poses are
// few, and needs O(P^2) memory; the sparse one (backend/sparse_information_factor.h) scales.
// The sparse factor takes over when an update would bring the pose dimension past
// max_dense_pose_dim, and when the dense factor cannot recover the state (S numerically
// indefinite although the update's check passed); it then factors the whole matrix.
//
// Between updates, an update may leave the factor inexact (the state from conjugate
// gradients) unless it is asked to keep it exact, or a query needed the exact factor since
// the last update: the selector asks once per added frame, and refactoring at the update
// (in the trailing window, usually) costs less than a lazy update and a refactor at the
// query.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "backend/information_factor.h"

namespace ieslam {

class DenseThenSparseFactor final : public InformationFactor {
 public:
  using Factory = std::function<std::unique_ptr<InformationFactor>()>;

  // `make_dense` factors the matrix while 6 * poses <= max_dense_pose_dim (never when that
  // is below 6), `make_sparse` from then on.
  DenseThenSparseFactor(int max_dense_pose_dim, Factory make_dense, Factory make_sparse);

  FactorStatus AddAndSolve(const UpperColumnStorage& matrix, const InformationUpdate& update,
                           bool keep_exact, const Eigen::VectorXd& info_vector,
                           const Eigen::VectorXd& guess, Eigen::VectorXd* state) override;
  void AddDeferred(const UpperColumnStorage& matrix, const InformationUpdate& update) override;
  void Restore(const UpperColumnStorage& matrix, bool factored) override {
    active_->Restore(matrix, factored);
  }
  bool Refactor(const UpperColumnStorage& matrix) override { return active_->Refactor(matrix); }

  // Also keeps the next update exact.
  void MakeExact() override;
  Eigen::VectorXd Solve(const Eigen::VectorXd& info_vector) const override {
    return active_->Solve(info_vector);
  }
  double LogDet() const override { return active_->LogDet(); }
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const override {
    return active_->InverseSubmatrix(indices);
  }
  int64_t FactorNonzeros() const override { return active_->FactorNonzeros(); }
  const FactorTimings& timings() const override { return active_->timings(); }
  bool uses_pose_schur() const override { return active_->uses_pose_schur(); }

 private:
  // Past max_dense_pose_dim with the next pose: the sparse factor takes over.
  void HandOverIfFull();
  // The sparse factor takes over for good; it factors the whole matrix at its first update.
  void HandOver();

  int max_dense_pose_dim_;
  Factory make_sparse_;
  std::unique_ptr<InformationFactor> active_;
  bool dense_ = false;  // active_ came from make_dense
  int num_poses_ = 0;
  bool queried_ = false;  // a query made the factor exact since the last update
};

}  // namespace ieslam
