// The InformationFactor contract, on both implementations: the sparse CHOLMOD factor and the
// dense pose Schur complement, each against the dense inverse of the same matrix.
#include "backend/information_factor.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/pose_schur_information_factor.h"
#include "backend/random_pose_problem.h"
#include "backend/sparse_information_factor.h"
#include "backend/upper_column_storage.h"

namespace ieslam {
namespace {

std::unique_ptr<InformationFactor> MakeFactor(bool dense) {
  if (dense) return MakePoseSchurInformationFactor(PoseSchurOptions());
  return MakeSparseInformationFactor({FillReducingOrdering::kMetis, 0.5});
}

class InformationFactorTest : public ::testing::TestWithParam<bool> {
 protected:
  // Adds pose k to the matrix and the factor; the factor's status.
  FactorStatus Add(int k, bool keep_exact, Eigen::VectorXd* state) {
    const testing::PoseAddition a = problem_.Next(k);
    testing::AppendToMatrix(a, &matrix_);
    info_vector_ = problem_.RandomVector(problem_.dim);
    Eigen::VectorXd guess = Eigen::VectorXd::Zero(problem_.dim);
    return factor_->AddAndSolve(matrix_, testing::UpdateOf(a), keep_exact, info_vector_, guess,
                                state);
  }

  // The factor's answers are the dense matrix's.
  void ExpectAgreement() {
    factor_->MakeExact();
    const Eigen::LLT<Eigen::MatrixXd> llt(problem_.I);
    const Eigen::VectorXd x = llt.solve(info_vector_);
    EXPECT_LT((factor_->Solve(info_vector_) - x).norm(), 1e-9 * x.norm());
    const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
    EXPECT_NEAR(factor_->LogDet(), log_det, 1e-9 * std::abs(log_det));
    const std::vector<int> indices = {problem_.pose_offsets[2] + 4,
                                      problem_.offset_of.begin()->second + 1,
                                      problem_.pose_offsets.back()};
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(problem_.dim, 3);
    for (int c = 0; c < 3; ++c) unit(indices[c], c) = 1.0;
    const Eigen::MatrixXd expected = llt.solve(unit)(indices, Eigen::all);
    EXPECT_LT((factor_->InverseSubmatrix(indices) - expected).norm(), 1e-9 * expected.norm());
    EXPECT_GT(factor_->FactorNonzeros(), 0);
  }

  testing::RandomPoseProblem problem_{21};
  UpperColumnStorage matrix_;
  Eigen::VectorXd info_vector_;
  std::unique_ptr<InformationFactor> factor_ = MakeFactor(GetParam());
};

INSTANTIATE_TEST_SUITE_P(Factorisations, InformationFactorTest, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? std::string("PoseSchur") : std::string("Sparse");
                         });

// Through the trajectory's returns, each state is the dense solve's (iteratively or not),
// and the queries agree.
TEST_P(InformationFactorTest, StatesAndQueriesAreTheDenseMatrixs) {
  EXPECT_EQ(factor_->uses_pose_schur(), GetParam());
  for (int k = 0; k < 40; ++k) {
    Eigen::VectorXd state;
    ASSERT_EQ(Add(k, /*keep_exact=*/k % 5 == 0, &state), FactorStatus::kOk) << "pose " << k;
    const Eigen::VectorXd x = Eigen::LLT<Eigen::MatrixXd>(problem_.I).solve(info_vector_);
    // The dense factor's CG stops at 1e-10 of a standard deviation.
    EXPECT_LT((state - x).norm(), 1e-6 * x.norm()) << "pose " << k;
    if (k % 13 == 12) ExpectAgreement();
  }
  ExpectAgreement();
}

// A refused update leaves the factor as it was, for the matrix as it was (after Restore),
// and the next updates go on as if it had never come.
TEST_P(InformationFactorTest, ARefusedUpdateLeavesTheFactorAsItWas) {
  Eigen::VectorXd state;
  for (int k = 0; k < 20; ++k) ASSERT_EQ(Add(k, false, &state), FactorStatus::kOk);
  factor_->MakeExact();
  const Eigen::VectorXd before = factor_->Solve(info_vector_);
  const double log_det = factor_->LogDet();
  const testing::PoseAddition singular = testing::SingularPose(problem_);
  UpperColumnStorage with = matrix_;
  testing::AppendToMatrix(singular, &with);
  Eigen::VectorXd info = info_vector_;
  info.conservativeResizeLike(Eigen::VectorXd::Zero(problem_.dim + 6));
  EXPECT_EQ(factor_->AddAndSolve(with, testing::UpdateOf(singular), false, info, info, &state),
            FactorStatus::kNotPositiveDefinite);
  factor_->Restore(matrix_, /*factored=*/true);
  factor_->MakeExact();
  if (GetParam()) {  // the dense factor is untouched
    EXPECT_EQ(factor_->Solve(info_vector_), before);
    EXPECT_EQ(factor_->LogDet(), log_det);
  } else {  // the sparse one, refactored
    EXPECT_LT((factor_->Solve(info_vector_) - before).norm(), 1e-12 * before.norm());
    EXPECT_NEAR(factor_->LogDet(), log_det, 1e-12 * std::abs(log_det));
  }
  for (int k = 20; k < 30; ++k) ASSERT_EQ(Add(k, false, &state), FactorStatus::kOk);
  ExpectAgreement();
}

// Deferred updates, one factorisation, then ordinary updates.
TEST_P(InformationFactorTest, DeferredUpdatesThenRefactor) {
  for (int k = 0; k < 25; ++k) {
    const testing::PoseAddition a = problem_.Next(k);
    testing::AppendToMatrix(a, &matrix_);
    factor_->AddDeferred(matrix_, testing::UpdateOf(a));
  }
  ASSERT_TRUE(factor_->Refactor(matrix_));
  info_vector_ = problem_.RandomVector(problem_.dim);
  ExpectAgreement();
  Eigen::VectorXd state;
  for (int k = 25; k < 30; ++k) ASSERT_EQ(Add(k, false, &state), FactorStatus::kOk);
  ExpectAgreement();
}

}  // namespace
}  // namespace ieslam
