#include "backend/sparse_information_factor.h"

#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/random_pose_problem.h"
#include "backend/upper_column_storage.h"

namespace ieslam {
namespace {

// `poses` poses of a random problem in the matrix and the factor.
void AddPoses(int poses, testing::RandomPoseProblem* problem, UpperColumnStorage* matrix,
              InformationFactor* factor) {
  Eigen::VectorXd state;
  for (int k = 0; k < poses; ++k) {
    const testing::PoseAddition a = problem->Next(k);
    testing::AppendToMatrix(a, matrix);
    const Eigen::VectorXd i = Eigen::VectorXd::Ones(problem->dim);
    ASSERT_EQ(factor->AddAndSolve(*matrix, testing::UpdateOf(a), false, i, i, &state),
              FactorStatus::kOk);
    EXPECT_EQ(factor->timings().cg_iterations, 0);
  }
  const Eigen::VectorXd i = Eigen::VectorXd::Ones(problem->dim);
  const Eigen::VectorXd x = Eigen::LLT<Eigen::MatrixXd>(problem->I).solve(i);
  EXPECT_LT((state - x).norm(), 1e-9 * x.norm());
}

// A new pose with no information, re-observing a feature: the in-place update and the
// refactorisation both fail, and the factor is dropped.
FactorStatus AddSingularPose(const testing::RandomPoseProblem& problem,
                             const UpperColumnStorage& matrix, InformationFactor* factor) {
  const testing::PoseAddition singular = testing::SingularPose(problem);
  UpperColumnStorage with = matrix;
  testing::AppendToMatrix(singular, &with);
  const Eigen::VectorXd i = Eigen::VectorXd::Ones(problem.dim + 6);
  Eigen::VectorXd state;
  return factor->AddAndSolve(with, testing::UpdateOf(singular), false, i, i, &state);
}

// Restore makes the factor one of the old matrix again when the refusal dropped it, unless
// that matrix had not been factored (deferred updates pending).
TEST(SparseInformationFactorTest, RestoreRefactorsTheOldMatrixOnlyIfItHadBeenFactored) {
  for (const bool factored : {true, false}) {
    testing::RandomPoseProblem problem(3);
    UpperColumnStorage matrix;
    const auto factor = MakeSparseInformationFactor({FillReducingOrdering::kMetis, 1.0});
    AddPoses(12, &problem, &matrix, factor.get());
    EXPECT_GT(factor->FactorNonzeros(), 0);
    EXPECT_EQ(AddSingularPose(problem, matrix, factor.get()), FactorStatus::kNotPositiveDefinite);
    EXPECT_EQ(factor->FactorNonzeros(), 0);  // dropped
    factor->Restore(matrix, factored);
    EXPECT_EQ(factor->FactorNonzeros() > 0, factored);
  }
}

TEST(SparseInformationFactorTest, IsExactAndNotThePoseSchurComplement) {
  testing::RandomPoseProblem problem(4);
  UpperColumnStorage matrix;
  // No spare slots: a full factorisation at every update.
  const auto factor = MakeSparseInformationFactor({FillReducingOrdering::kAmd, 0.0});
  AddPoses(10, &problem, &matrix, factor.get());
  EXPECT_FALSE(factor->uses_pose_schur());
  factor->MakeExact();  // nothing to do
  const Eigen::LLT<Eigen::MatrixXd> llt(problem.I);
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  EXPECT_NEAR(factor->LogDet(), log_det, 1e-9 * std::abs(log_det));
  EXPECT_GT(factor->timings().analyze_s, 0.0);
}

}  // namespace
}  // namespace ieslam
