#include "backend/windowed_pose_cholesky.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

namespace ieslam {
namespace {

constexpr int kPoses = 20;

// A random symmetric positive definite matrix of `poses` 6x6 blocks, each pose coupled to
// its neighbours in time and, from pose 10 on, to pose 2 (a loop closure).
Eigen::MatrixXd RandomS(int poses, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const int n = 6 * poses;
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, n);
  for (int a = 0; a < poses; ++a) {
    for (int b = 0; b <= a; ++b) {
      if (a - b > 2 && !(a >= 10 && b == 2)) continue;
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < 6; ++c) S(6 * a + r, 6 * b + c) = 0.3 * uniform(*rng);
      }
    }
  }
  S = (S + S.transpose()).eval();
  S.diagonal().array() += 12.0;
  return S;
}

// Scalar rows of the poses in `order`.
std::vector<int> Rows(const std::vector<int>& order) {
  std::vector<int> rows;
  for (const int pose : order) {
    for (int c = 0; c < 6; ++c) rows.push_back(6 * pose + c);
  }
  return rows;
}

// The poses in factor order.
std::vector<int> Order(const WindowedPoseCholesky& factor) {
  std::vector<int> order(factor.num_factored());
  for (int pose = 0; pose < factor.num_factored(); ++pose) order[factor.position()[pose]] = pose;
  return order;
}

// The factor solves S (its factored poses, in its order).
void ExpectSolves(const WindowedPoseCholesky& factor, const Eigen::MatrixXd& S) {
  const std::vector<int> rows = Rows(Order(factor));
  const Eigen::LLT<Eigen::MatrixXd> llt(S(rows, rows));
  Eigen::VectorXd z = Eigen::VectorXd::LinSpaced(static_cast<int>(rows.size()), -1.0, 2.0);
  const Eigen::VectorXd expected = llt.solve(z);
  factor.Substitute(z, /*single=*/false);
  EXPECT_LT((z - expected).norm(), 1e-12 * expected.norm());
}

// The factor is exact: it solves S (in its order), and gives its log det and quadratic
// forms of its inverse.
void ExpectFactors(const WindowedPoseCholesky& factor, const Eigen::MatrixXd& S,
                   std::mt19937* rng) {
  ASSERT_TRUE(factor.exact());
  ExpectSolves(factor, S);
  const std::vector<int> rows = Rows(Order(factor));
  const Eigen::LLT<Eigen::MatrixXd> llt(S(rows, rows));
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  EXPECT_NEAR(factor.LogDetS(), log_det, 1e-12 * std::abs(log_det));
  // Columns zero above rows 0, 30 and 90 (more than one group of 48).
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(S.rows(), 100);
  std::vector<int> first_row(100);
  for (int c = 0; c < 100; ++c) {
    first_row[c] = c % 3 == 0 ? 0 : c % 3 == 1 ? 30 : 90;
    for (int r = first_row[c]; r < S.rows(); ++r) R(r, c) = uniform(*rng);
  }
  const Eigen::MatrixXd form = R.transpose() * llt.solve(R);
  EXPECT_LT((factor.QuadraticForm(R, first_row) - form).norm(), 1e-12 * form.norm());
}

class WindowedPoseCholeskyTest : public ::testing::Test {
 protected:
  // kPoses poses, each added by an update that touched nothing else, then factored.
  void SetUp() override {
    factor_.Reserve(6 * (kPoses + 1));
    for (int k = 0; k < kPoses; ++k) factor_.AddPose({});
    S_ = RandomS(kPoses + 1, &rng_);  // the last pose comes later
    ASSERT_TRUE(factor_.FactorFrom(factor_.PlanAll(), S_, nullptr));
  }

  std::mt19937 rng_{5};
  WindowedPoseCholesky factor_{/*prefetch=*/1, /*evict_after=*/3};
  Eigen::MatrixXd S_;
};

TEST_F(WindowedPoseCholeskyTest, PlanAllPutsTheRecentlyTouchedPosesLast) {
  EXPECT_EQ(factor_.window_start(), kPoses - 2);  // touched by the last two updates
  std::vector<int> natural(kPoses);
  for (int q = 0; q < kPoses; ++q) natural[q] = q;
  EXPECT_EQ(Order(factor_), natural);
  ExpectFactors(factor_, S_.topLeftCorner(6 * kPoses, 6 * kPoses), &rng_);
}

// A pose touched outside the window moves in with its neighbours in time; the poses
// untouched for a while leave the window at its front; the factor from the first moved
// position on is recomputed from S.
TEST_F(WindowedPoseCholeskyTest, TouchedPosesMoveIntoTheWindow) {
  factor_.AddPose({2});
  EXPECT_EQ(factor_.num_poses(), kPoses + 1);
  EXPECT_EQ(factor_.DirtyPoses(), std::vector<int>{2});
  const WindowedPoseCholesky::Plan plan = factor_.PlanWindow(factor_.DirtyPoses());
  EXPECT_EQ(plan.first, 1);
  // Before the window: the poses not moved, then pose 18, untouched by the last three
  // updates; in it: pose 19, the moved poses 1-3 (prefetch 1) and the new pose.
  std::vector<int> expected = {0};
  for (int q = 4; q <= 18; ++q) expected.push_back(q);
  const int window_start = static_cast<int>(expected.size());
  for (const int pose : {19, 1, 2, 3, kPoses}) expected.push_back(pose);
  EXPECT_EQ(plan.order, expected);
  EXPECT_EQ(plan.window_start, window_start);
  ASSERT_TRUE(factor_.FactorFrom(plan, S_, nullptr));
  EXPECT_TRUE(factor_.DirtyPoses().empty());
  ExpectFactors(factor_, S_, &rng_);
}

// An update that touches only the window refactors its C plus the change: the same factor
// as one formed from S.
TEST_F(WindowedPoseCholeskyTest, AnUpdateOfTheWindowRefactorsItsTrailingBlockOnly) {
  // The update: pose 19's block grows, and the new pose comes coupled to it alone. D holds
  // the change on pose 19, then the new pose.
  for (int b = 0; b < kPoses - 1; ++b) {
    S_.block(6 * kPoses, 6 * b, 6, 6).setZero();
    S_.block(6 * b, 6 * kPoses, 6, 6).setZero();
  }
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(12, 12);
  D.topLeftCorner(6, 6) = Eigen::MatrixXd::Identity(6, 6);
  S_.block(6 * (kPoses - 1), 6 * (kPoses - 1), 6, 6) += D.topLeftCorner(6, 6);
  D.bottomRows(6) = S_.bottomRows(6)(Eigen::all, Rows({kPoses - 1, kPoses}));
  D.rightCols(6) = D.bottomRows(6).transpose();

  factor_.AddPose({kPoses - 1});
  const WindowedPoseCholesky::Plan plan = factor_.PlanWindow(factor_.DirtyPoses());
  ASSERT_EQ(plan.first, factor_.window_start());
  std::vector<int> local(kPoses, -1);
  local[kPoses - 1] = 0;
  const Eigen::MatrixXd T = factor_.UpdatedWindow(plan, local, D);
  WindowedPoseCholesky from_S = factor_;
  ASSERT_TRUE(factor_.FactorFrom(plan, S_, &T));
  ASSERT_TRUE(from_S.FactorFrom(plan, S_, nullptr));
  ExpectFactors(factor_, S_, &rng_);
  ExpectFactors(from_S, S_, &rng_);
}

// A renewal in float leaves a preconditioner: the double factor is exact in its leading
// columns only, the float one solves to float precision, and the next exact factorisation
// starts from those columns.
TEST_F(WindowedPoseCholeskyTest, RenewalInFloatLeavesAPreconditioner) {
  factor_.AddPose({2});
  ASSERT_TRUE(factor_.RenewInSingle(factor_.PlanWindow(factor_.DirtyPoses()), S_));
  EXPECT_TRUE(factor_.valid());
  EXPECT_FALSE(factor_.exact());
  EXPECT_EQ(factor_.double_columns(), 1);
  const std::vector<int> rows = Rows(Order(factor_));
  const Eigen::LLT<Eigen::MatrixXd> llt(S_(rows, rows));
  Eigen::VectorXd z = Eigen::VectorXd::LinSpaced(S_.rows(), -1.0, 1.0);
  const Eigen::VectorXd expected = llt.solve(z);
  factor_.Substitute(z, /*single=*/true);
  EXPECT_LT((z - expected).norm(), 1e-4 * expected.norm());
  EXPECT_GT((z - expected).norm(), 0.0);  // float, not double
  ASSERT_TRUE(factor_.FactorFrom(factor_.PlanWindow(factor_.DirtyPoses()), S_, nullptr));
  ExpectFactors(factor_, S_, &rng_);
}

TEST_F(WindowedPoseCholeskyTest, RemoveLastPoseRestoresTheTouchRecord) {
  const WindowedPoseCholesky::Plan before = factor_.PlanWindow({2});
  const std::vector<int> previous = factor_.AddPose({2, kPoses - 1});
  factor_.RemoveLastPose({2, kPoses - 1}, previous);
  EXPECT_EQ(factor_.num_poses(), kPoses);
  EXPECT_TRUE(factor_.DirtyPoses().empty());
  const WindowedPoseCholesky::Plan after = factor_.PlanWindow({2});
  EXPECT_EQ(after.order, before.order);
  EXPECT_EQ(after.first, before.first);
  EXPECT_EQ(after.window_start, before.window_start);
}

TEST_F(WindowedPoseCholeskyTest, AFactorisationThatFailsChangesNothing) {
  factor_.AddPose({2});
  Eigen::MatrixXd indefinite = S_;
  indefinite.bottomRightCorner(6, 6) = -Eigen::MatrixXd::Identity(6, 6);
  const WindowedPoseCholesky::Plan plan = factor_.PlanWindow(factor_.DirtyPoses());
  EXPECT_FALSE(factor_.FactorFrom(plan, indefinite, nullptr));
  EXPECT_FALSE(factor_.RenewInSingle(plan, indefinite));
  EXPECT_TRUE(factor_.valid());
  EXPECT_EQ(factor_.num_factored(), kPoses);
  ExpectSolves(factor_, S_);
}

}  // namespace
}  // namespace ieslam
