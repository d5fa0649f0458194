#include "backend/lazy_pose_solver.h"

#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/random_pose_problem.h"

namespace ieslam {
namespace {

constexpr int kFactored = 20;
constexpr int kLazy = 4;

// kFactored poses taken into the blocks and factored exactly, then kLazy more taken in
// lazily (S and its factor left behind) and the preconditioner prepared, as PoseSchurFactor
// does it.
class LazyPoseSolverTest : public ::testing::Test {
 protected:
  void SetUp() override {
    blocks_.Reserve(6 * (kFactored + kLazy));
    factor_.Reserve(6 * (kFactored + kLazy));
    for (int k = 0; k < kFactored; ++k) Add(k, /*lazy=*/false);
    ASSERT_TRUE(factor_.FactorFrom(factor_.PlanAll(), blocks_.S(), nullptr));
    S_then_ = problem_.DenseSchur();
    for (int k = kFactored; k < kFactored + kLazy; ++k) Add(k, /*lazy=*/true);
    ASSERT_TRUE(solver_.Prepare(blocks_, &factor_));
  }

  void Add(int k, bool lazy) {
    const testing::PoseAddition a = problem_.Next(k);
    if (!lazy) blocks_.Sync();
    const PoseSchurBlocks::Change change =
        blocks_.ComputeChange(a.I_pp, a.observations, blocks_.TouchedPoses(a.observations), !lazy);
    blocks_.AddPose(a.pose_offset, a.I_pp, a.observations, change, !lazy);
    factor_.AddPose(change.touched);
  }

  // Scalar rows, in pose order, of the factor's positions.
  std::vector<int> Rows() const {
    std::vector<int> order(factor_.num_poses());
    for (int pose = 0; pose < factor_.num_poses(); ++pose) order[factor_.position()[pose]] = pose;
    std::vector<int> rows;
    for (const int pose : order) {
      for (int c = 0; c < 6; ++c) rows.push_back(6 * pose + c);
    }
    return rows;
  }

  testing::RandomPoseProblem problem_{11};
  PoseSchurBlocks blocks_;
  WindowedPoseCholesky factor_{/*prefetch=*/2, /*evict_after=*/3};
  LazyPoseSolver solver_{/*cg_tolerance=*/1e-10, /*cg_max_iterations=*/60,
                         /*cg_flop_weight=*/2.0};
  Eigen::MatrixXd S_then_;  // S when it was factored
};

// The preconditioner is M = [M_old + B C^-1 B^T, B; B^T, C] with M_old the old factor's
// L L^T and B, C S's blocks of the lazy poses now: M^-1 z by block elimination.
TEST_F(LazyPoseSolverTest, ThePreconditionerIsTheOldFactorWithTheNewPosesEliminated) {
  EXPECT_FALSE(factor_.exact());
  EXPECT_EQ(factor_.num_factored(), kFactored);
  const std::vector<int> rows = Rows();
  const int old_n = 6 * kFactored, lazy_n = 6 * kLazy;
  std::vector<int> old_rows(rows.begin(), rows.begin() + old_n);
  const Eigen::MatrixXd S_now = problem_.DenseSchur()(rows, rows);
  const Eigen::MatrixXd B = S_now.topRightCorner(old_n, lazy_n);
  const Eigen::MatrixXd C = S_now.bottomRightCorner(lazy_n, lazy_n);
  Eigen::MatrixXd M(old_n + lazy_n, old_n + lazy_n);
  M.topLeftCorner(old_n, old_n) = S_then_(old_rows, old_rows) + B * C.llt().solve(B.transpose());
  M.topRightCorner(old_n, lazy_n) = B;
  M.bottomLeftCorner(lazy_n, old_n) = B.transpose();
  M.bottomRightCorner(lazy_n, lazy_n) = C;
  Eigen::VectorXd z = Eigen::VectorXd::LinSpaced(old_n + lazy_n, -1.0, 1.0);
  const Eigen::VectorXd expected = M.llt().solve(z);
  solver_.ApplyPreconditioner(factor_, /*single=*/false, &z);
  EXPECT_LT((z - expected).norm(), 1e-9 * expected.norm());
}

// Conjugate gradients with the float copy of the old factor solve I X = i as the dense
// solve does, and record their iterations and cost.
TEST_F(LazyPoseSolverTest, ConjugateGradientsSolveAsTheDenseFactor) {
  factor_.SyncSingle();
  const Eigen::VectorXd i = problem_.RandomVector(problem_.dim);
  const Eigen::VectorXd expected = Eigen::LLT<Eigen::MatrixXd>(problem_.I).solve(i);
  Eigen::VectorXd x;
  ASSERT_TRUE(solver_.Solve(blocks_, factor_, i, Eigen::VectorXd::Zero(problem_.dim), &x));
  EXPECT_LT((x - expected).norm(), 1e-9 * expected.norm());
  EXPECT_GT(solver_.last_iterations(), 0);
  EXPECT_EQ(solver_.baseline_iterations(), solver_.last_iterations());
  EXPECT_GT(solver_.lazy_flops(), 0.0);  // the preparation's
  // From the solution, nothing is left to do.
  Eigen::VectorXd again;
  ASSERT_TRUE(solver_.Solve(blocks_, factor_, i, x, &again));
  EXPECT_LE(solver_.last_iterations(), 1);
  solver_.NoteSubstitution();
  EXPECT_EQ(solver_.last_iterations(), 0);
  solver_.Reset();
  EXPECT_EQ(solver_.lazy_flops(), 0.0);
  EXPECT_EQ(solver_.baseline_iterations(), -1);
}

// Too few iterations allowed: the last iterate, and false.
TEST_F(LazyPoseSolverTest, CgThatDoesNotConvergeSaysSo) {
  factor_.SyncSingle();
  LazyPoseSolver one_step(1e-10, 1, 2.0);
  ASSERT_TRUE(one_step.Prepare(blocks_, &factor_));
  Eigen::VectorXd x;
  EXPECT_FALSE(one_step.Solve(blocks_, factor_, problem_.RandomVector(problem_.dim),
                              Eigen::VectorXd::Zero(problem_.dim), &x));
  EXPECT_EQ(one_step.last_iterations(), 1);
  EXPECT_EQ(x.size(), problem_.dim);
}

// A lazy pose with no information makes C, and so S, not positive definite.
TEST_F(LazyPoseSolverTest, PrepareRefusesAnIndefiniteBlockOfNewPoses) {
  ObservationBlocks obs;
  obs.feature_offset = problem_.offset_of.begin()->second;
  const std::vector<ObservationBlocks> observations = {obs};
  const Eigen::Matrix<double, 6, 6> zero = Eigen::Matrix<double, 6, 6>::Zero();
  const PoseSchurBlocks::Change change =
      blocks_.ComputeChange(zero, observations, blocks_.TouchedPoses(observations), false);
  blocks_.AddPose(problem_.dim, zero, observations, change, false);
  factor_.AddPose(change.touched);
  const std::vector<int> position = factor_.position();
  EXPECT_FALSE(solver_.Prepare(blocks_, &factor_));
  EXPECT_EQ(factor_.position(), position);
}

}  // namespace
}  // namespace ieslam
