#include "backend/pose_schur_information_factor.h"

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/random_pose_problem.h"
#include "backend/upper_column_storage.h"
#include "core/error.h"

namespace ieslam {
namespace {

// Adds pose k; the state's error against the dense solve, relative.
double AddPose(int k, bool keep_exact, testing::RandomPoseProblem* problem,
               UpperColumnStorage* matrix, InformationFactor* factor) {
  const testing::PoseAddition a = problem->Next(k);
  testing::AppendToMatrix(a, matrix);
  const Eigen::VectorXd i = problem->RandomVector(problem->dim);
  Eigen::VectorXd state;
  EXPECT_EQ(factor->AddAndSolve(*matrix, testing::UpdateOf(a), keep_exact, i,
                                Eigen::VectorXd::Zero(problem->dim), &state),
            FactorStatus::kOk);
  const Eigen::VectorXd x = Eigen::LLT<Eigen::MatrixXd>(problem->I).solve(i);
  return (state - x).norm() / x.norm();
}

// Updates that may stay inexact recover the state by conjugate gradients (lazy whenever
// possible, cg_flop_weight 0); updates that must be exact substitute.
TEST(PoseSchurInformationFactorTest, OnlyUpdatesThatMayStayInexactUseConjugateGradients) {
  PoseSchurOptions options;
  options.cg_flop_weight = 0.0;
  const auto factor = MakePoseSchurInformationFactor(options);
  EXPECT_TRUE(factor->uses_pose_schur());
  testing::RandomPoseProblem problem(8);
  UpperColumnStorage matrix;
  int iterative = 0;
  for (int k = 0; k < 30; ++k) {
    EXPECT_LT(AddPose(k, /*keep_exact=*/false, &problem, &matrix, factor.get()), 1e-6) << k;
    iterative += factor->timings().cg_iterations > 0 ? 1 : 0;
  }
  EXPECT_GT(iterative, 10);
  for (int k = 30; k < 36; ++k) {
    EXPECT_LT(AddPose(k, /*keep_exact=*/true, &problem, &matrix, factor.get()), 1e-9) << k;
    EXPECT_EQ(factor->timings().cg_iterations, 0) << k;
  }
}

// CG stopped after one iteration: the factor is made exact instead, and the state is the
// exact one.
TEST(PoseSchurInformationFactorTest, UnconvergedConjugateGradientsFallBackToTheExactFactor) {
  PoseSchurOptions options;
  options.cg_flop_weight = 0.0;
  options.cg_max_iterations = 1;
  const auto factor = MakePoseSchurInformationFactor(options);
  testing::RandomPoseProblem problem(9);
  UpperColumnStorage matrix;
  bool fell_back = false;
  for (int k = 0; k < 30; ++k) {
    EXPECT_LT(AddPose(k, false, &problem, &matrix, factor.get()), 1e-9) << k;
    fell_back = fell_back || factor->timings().cg_iterations == 1;
  }
  EXPECT_TRUE(fell_back);
}

TEST(PoseSchurInformationFactorTest, BadOptionsAreAConfigError) {
  PoseSchurOptions options;
  options.evict_after = 0;
  EXPECT_THROW(MakePoseSchurInformationFactor(options), ConfigError);
}

}  // namespace
}  // namespace ieslam
