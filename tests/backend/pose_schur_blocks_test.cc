#include "backend/pose_schur_blocks.h"

#include <cmath>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/random_pose_problem.h"

namespace ieslam {
namespace {

// Adds pose k of `problem` to `blocks`, updating S when `update_S` (after a Sync, as the
// factor does) and leaving it behind otherwise.
void Add(int k, bool update_S, testing::RandomPoseProblem* problem, PoseSchurBlocks* blocks) {
  const testing::PoseAddition a = problem->Next(k);
  if (update_S) {
    blocks->Reserve(blocks->dim() + 6);
    blocks->Sync();
  }
  const PoseSchurBlocks::Change change =
      blocks->ComputeChange(a.I_pp, a.observations, blocks->TouchedPoses(a.observations), update_S);
  blocks->AddPose(a.pose_offset, a.I_pp, a.observations, change, update_S);
}

// S's lower 6x6 blocks as a full symmetric matrix.
Eigen::MatrixXd FullS(const PoseSchurBlocks& blocks) {
  const int n = blocks.dim();
  Eigen::MatrixXd S = blocks.S().topLeftCorner(n, n);
  for (int b = 0; b < n / 6; ++b) {
    for (int a = b + 1; a < n / 6; ++a)
      S.block<6, 6>(6 * b, 6 * a) = S.block<6, 6>(6 * a, 6 * b).transpose();
  }
  return S;
}

std::vector<int> Identity(int n) {
  std::vector<int> position(n);
  std::iota(position.begin(), position.end(), 0);
  return position;
}

// Through updates of S and lazy additions that leave it behind, S after a Sync is the pose
// Schur complement of I, and the products with S from the blocks agree with it all along.
TEST(PoseSchurBlocksTest, SAndItsProductsAreThePoseSchurComplement) {
  testing::RandomPoseProblem problem(1);
  PoseSchurBlocks blocks;
  for (int k = 0; k < 30; ++k) {
    Add(k, /*update_S=*/k % 3 == 0, &problem, &blocks);
    const Eigen::MatrixXd S = problem.DenseSchur();
    const Eigen::VectorXd x = problem.RandomVector(blocks.dim());
    Eigen::VectorXd y;
    blocks.MultiplyS(x, Identity(blocks.num_poses()), &y);
    EXPECT_LT((y - S * x).norm(), 1e-9 * (S * x).norm()) << "pose " << k;
  }
  EXPECT_EQ(blocks.num_poses(), 30);
  EXPECT_EQ(blocks.num_couplings(), 30 * 9);
  blocks.Reserve(blocks.dim());
  blocks.Sync();
  const Eigen::MatrixXd S = problem.DenseSchur();
  EXPECT_LT((FullS(blocks) - S).norm(), 1e-9 * S.norm());
  // log det I = sum log det F + log det S.
  const Eigen::LLT<Eigen::MatrixXd> llt_I(problem.I), llt_S(S);
  const double log_det_I = 2.0 * llt_I.matrixLLT().diagonal().array().log().sum();
  const double log_det_S = 2.0 * llt_S.matrixLLT().diagonal().array().log().sum();
  EXPECT_NEAR(blocks.FeatureLogDet() + log_det_S, log_det_I, 1e-9 * std::abs(log_det_I));
}

// The reduced right-hand side, solved with the dense S, and the back-substitution of the
// features give I^-1 i; the columns of the inverse give I^-1's entries; the poses in a
// scrambled factor order change nothing.
TEST(PoseSchurBlocksTest, ReducedSystemAndInverseColumnsRecoverI) {
  testing::RandomPoseProblem problem(2);
  PoseSchurBlocks blocks;
  for (int k = 0; k < 20; ++k) Add(k, /*update_S=*/true, &problem, &blocks);
  const int poses = blocks.num_poses();
  std::vector<int> order(poses);  // position -> pose
  for (int q = 0; q < poses; ++q) order[q] = (7 * q) % poses;
  std::vector<int> position(poses);
  for (int q = 0; q < poses; ++q) position[order[q]] = q;
  std::vector<int> scalar;  // factor row -> pose-order row
  for (const int pose : order) {
    for (int c = 0; c < 6; ++c) scalar.push_back(6 * pose + c);
  }
  const Eigen::MatrixXd S = problem.DenseSchur()(scalar, scalar);
  const Eigen::LLT<Eigen::MatrixXd> llt_S(S), llt_I(problem.I);

  const Eigen::VectorXd i = problem.RandomVector(problem.dim);
  const Eigen::VectorXd x_p = llt_S.solve(blocks.ReducedRhs(i, position));
  const Eigen::VectorXd x = llt_I.solve(i);
  EXPECT_LT((blocks.FullState(i, x_p, position) - x).norm(), 1e-9 * x.norm());

  const std::vector<int> indices = {problem.pose_offsets[3] + 1, problem.offset_of.begin()->second,
                                    problem.offset_of.begin()->second + 2,
                                    problem.pose_offsets.back() + 5};
  const PoseSchurBlocks::InverseColumns columns = blocks.ColumnsOf(indices, position);
  for (int c = 0; c < static_cast<int>(indices.size()); ++c) {
    EXPECT_EQ(columns.R.col(c).head(columns.first_row[c]).norm(), 0.0) << "column " << c;
  }
  Eigen::MatrixXd inverse = columns.R.transpose() * llt_S.solve(columns.R);
  blocks.AddFeatureInverses(columns, &inverse);
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(problem.dim, static_cast<int>(indices.size()));
  for (size_t c = 0; c < indices.size(); ++c) unit(indices[c], static_cast<int>(c)) = 1.0;
  const Eigen::MatrixXd expected = llt_I.solve(unit)(indices, Eigen::all);
  EXPECT_LT((inverse - expected).norm(), 1e-9 * expected.norm());
}

// S's blocks of the poses added lazily, from the blocks, are S's.
TEST(PoseSchurBlocksTest, SchurBlocksOfLaterPosesAreThoseOfS) {
  testing::RandomPoseProblem problem(3);
  PoseSchurBlocks blocks;
  for (int k = 0; k < 24; ++k) Add(k, /*update_S=*/k < 18, &problem, &blocks);
  Eigen::MatrixXd C, B;
  blocks.SchurBlocksOfPoses(18, Identity(24), &C, &B);
  const Eigen::MatrixXd S = problem.DenseSchur();
  EXPECT_LT((C - S.bottomRightCorner(36, 36)).norm(), 1e-9 * S.norm());
  EXPECT_LT((B - S.topRightCorner(108, 36)).norm(), 1e-9 * S.norm());
}

// Revert takes an addition back bit for bit: afterwards the blocks go on exactly as a twin
// that never saw it, with S updated and lazily.
TEST(PoseSchurBlocksTest, RevertTakesAnAdditionBackExactly) {
  for (const bool update_S : {true, false}) {
    SCOPED_TRACE(::testing::Message() << "update_S " << update_S);
    testing::RandomPoseProblem problem(4), twin_problem(4);
    PoseSchurBlocks blocks, twin;
    for (int k = 0; k < 15; ++k) {
      Add(k, k % 2 == 0, &problem, &blocks);
      Add(k, k % 2 == 0, &twin_problem, &twin);
    }
    // The next pose (new features and re-observed ones), taken back.
    testing::RandomPoseProblem scratch = problem;
    const testing::PoseAddition a = scratch.Next(15);
    if (update_S) {
      blocks.Reserve(blocks.dim() + 6);
      blocks.Sync();
    }
    const PoseSchurBlocks::Change change =
        blocks.ComputeChange(a.I_pp, a.observations, blocks.TouchedPoses(a.observations), update_S);
    const PoseSchurBlocks::Undo undo =
        blocks.AddPose(a.pose_offset, a.I_pp, a.observations, change, update_S);
    EXPECT_EQ(blocks.num_poses(), 16);
    blocks.Revert(undo);
    EXPECT_EQ(blocks.num_poses(), 15);
    EXPECT_FALSE(blocks.HasPoseAt(a.pose_offset));
    for (int k = 15; k < 30; ++k) {
      Add(k, k % 2 == 0, &problem, &blocks);
      Add(k, k % 2 == 0, &twin_problem, &twin);
    }
    blocks.Reserve(blocks.dim());
    twin.Reserve(twin.dim());
    blocks.Sync();
    twin.Sync();
    EXPECT_EQ(FullS(blocks), FullS(twin));
    EXPECT_EQ(blocks.FeatureLogDet(), twin.FeatureLogDet());
    const Eigen::VectorXd i = problem.RandomVector(problem.dim);
    EXPECT_EQ(blocks.ReducedRhs(i, Identity(30)), twin.ReducedRhs(i, Identity(30)));
  }
}

}  // namespace
}  // namespace ieslam
