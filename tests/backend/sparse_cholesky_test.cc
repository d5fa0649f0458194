#include "backend/sparse_cholesky.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "core/error.h"

namespace ieslam {
namespace {

// A random sparse SPD matrix of `blocks` 3x3 blocks, each coupled to a few earlier ones
// (like features and poses), appended column by column as the filter does.
void AppendRandomBlocks(int blocks, std::mt19937* rng, UpperColumnStorage* matrix,
                        Eigen::MatrixXd* dense) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int b = 0; b < blocks; ++b) {
    const int first = matrix->dim();
    dense->conservativeResize(first + 3, first + 3);
    dense->rightCols(3).setZero();
    dense->bottomRows(3).setZero();
    std::vector<int> coupled;  // earlier blocks, sorted
    for (int c = 0; c < std::min(3, first / 3); ++c) {
      coupled.push_back(std::uniform_int_distribution<int>(0, first / 3 - 1)(*rng));
    }
    std::sort(coupled.begin(), coupled.end());
    coupled.erase(std::unique(coupled.begin(), coupled.end()), coupled.end());
    for (int k = 0; k < 3; ++k) {
      matrix->StartColumn();
      for (const int block : coupled) {
        for (int r = 3 * block; r < 3 * block + 3; ++r) {
          const double value = 0.3 * uniform(*rng);
          matrix->Append(r, value);
          (*dense)(r, first + k) = (*dense)(first + k, r) = value;
        }
      }
      for (int r = first; r <= first + k; ++r) {
        const double value = r == first + k ? 6.0 : 0.5 * uniform(*rng);
        matrix->Append(r, value);
        (*dense)(r, first + k) = (*dense)(first + k, r) = value;
      }
    }
  }
  // Every block is diagonally dominant enough: 6 against at most 9 couplings of 0.3
  // upwards plus those from later blocks; the dense check below would catch a failure.
}

// InverseSubmatrix against a dense inverse, on a factor grown in place (simplicial LDL^T,
// the paths solved in column chunks) and on a one-shot supernodal factor, with more wanted
// variables than one chunk holds, asked in a scrambled order with a repeat.
TEST(SparseCholeskyTest, ManyInverseEntriesAgreeWithDenseInverse) {
  std::mt19937 rng(5);
  UpperColumnStorage matrix;
  Eigen::MatrixXd dense(0, 0);
  AppendRandomBlocks(60, &rng, &matrix, &dense);
  SparseCholesky incremental({FillReducingOrdering::kMetis, 1.0});
  ASSERT_TRUE(incremental.Factorize(matrix, true));
  // Grow in place: new rows and a low-rank update of an old block.
  for (int step = 0; step < 5; ++step) {
    const int old_dim = matrix.dim();
    const Eigen::Matrix3d increment = Eigen::Matrix3d::Identity() * (0.5 + step);
    const int first = 3 * (7 * step);
    matrix.AddToDiagonalBlock(first, increment);
    dense.block<3, 3>(first, first) += increment;
    AppendRandomBlocks(4, &rng, &matrix, &dense);
    ASSERT_TRUE(incremental.Update(matrix, old_dim, {{first, increment}})) << "step " << step;
  }
  SparseCholesky full({FillReducingOrdering::kAmd});
  ASSERT_TRUE(full.Factorize(matrix, true));

  const Eigen::LLT<Eigen::MatrixXd> llt(dense);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(dense.rows(), dense.rows()));
  std::vector<int> indices(matrix.dim());
  for (int i = 0; i < matrix.dim(); ++i) indices[i] = i;
  std::shuffle(indices.begin(), indices.end(), rng);
  indices.resize(130);  // more than two chunks
  indices.push_back(indices[3]);
  const Eigen::MatrixXd expected = inverse(indices, indices);
  const Eigen::MatrixXd from_incremental = incremental.InverseSubmatrix(indices);
  const Eigen::MatrixXd from_full = full.InverseSubmatrix(indices);
  EXPECT_LT((from_incremental - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((from_full - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(from_incremental, from_incremental.transpose());
  // A single entry (one short path).
  EXPECT_NEAR(incremental.InverseSubmatrix({5})(0, 0), inverse(5, 5), 1e-14);
}

// SparseCholesky on its own: in-place updates (diagonal increments, new rows) agree with a
// full factorisation, a non-positive-definite update is refused with the factor dropped,
// and a full factorisation then recovers.
TEST(SparseCholeskyTest, InPlaceUpdatesAgreeWithFullFactorisation) {
  std::mt19937 rng(18);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  // Dense SPD blocks of 3, each coupled to the previous one: appended column by column.
  auto append_block = [&](UpperColumnStorage* matrix, Eigen::MatrixXd* dense) {
    const int first = matrix->dim();
    dense->conservativeResize(first + 3, first + 3);
    dense->rightCols(3).setZero();
    dense->bottomRows(3).setZero();
    for (int k = 0; k < 3; ++k) {
      matrix->StartColumn();
      for (int r = std::max(0, first - 3); r <= first + k; ++r) {
        const double value = r == first + k ? 8.0 : 0.5 * uniform(rng);
        matrix->Append(r, value);
        (*dense)(r, first + k) = (*dense)(first + k, r) = value;
      }
    }
  };
  UpperColumnStorage matrix;
  Eigen::MatrixXd dense(0, 0);
  for (int b = 0; b < 4; ++b) append_block(&matrix, &dense);
  SparseCholesky incremental({FillReducingOrdering::kMetis, 1.0});
  ASSERT_TRUE(incremental.Factorize(matrix, true));
  for (int step = 0; step < 3; ++step) {
    const int old_dim = matrix.dim();
    Eigen::Matrix3d root;
    for (int k = 0; k < 9; ++k) root(k % 3, k / 3) = uniform(rng);
    const Eigen::Matrix3d increment = root * root.transpose();
    const int first = 3 * step;
    matrix.AddToDiagonalBlock(first, increment);
    dense.block<3, 3>(first, first) += increment;
    append_block(&matrix, &dense);
    ASSERT_TRUE(incremental.Update(matrix, old_dim, {{first, increment}})) << "step " << step;
  }
  SparseCholesky full({FillReducingOrdering::kAmd});
  ASSERT_TRUE(full.Factorize(matrix, true));
  const Eigen::LLT<Eigen::MatrixXd> llt(dense);
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  EXPECT_NEAR(incremental.LogDet(), log_det, 1e-12 * std::abs(log_det));
  EXPECT_NEAR(full.LogDet(), log_det, 1e-12 * std::abs(log_det));
  const Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(dense.rows(), -1.0, 2.0);
  EXPECT_LT((incremental.Solve(rhs) - llt.solve(rhs)).norm(), 1e-12);
  const std::vector<int> indices = {7, 0, 13, 2};
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(dense.rows(), dense.rows()));
  EXPECT_LT((incremental.InverseSubmatrix(indices) - inverse(indices, indices)).norm(), 1e-12);
  EXPECT_LT((full.InverseSubmatrix(indices) - inverse(indices, indices)).norm(), 1e-12);

  // A new variable coupled too strongly: not positive definite.
  const int old_dim = matrix.dim();
  matrix.StartColumn();
  matrix.Append(0, 20.0);
  matrix.Append(old_dim, 1.0);
  EXPECT_FALSE(incremental.Update(matrix, old_dim, {}));
  EXPECT_FALSE(incremental.valid());
  EXPECT_FALSE(incremental.Factorize(matrix, true));
  matrix.Truncate(old_dim);
  ASSERT_TRUE(incremental.Factorize(matrix, true));
  EXPECT_NEAR(incremental.LogDet(), log_det, 1e-12 * std::abs(log_det));
}

TEST(SparseCholeskyTest, OptionsCheckRejectsANegativeOrNonFiniteSpareCapacity) {
  SparseCholeskyOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why)) << why;
  options.spare_capacity = -0.1;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("spare_capacity"), std::string::npos) << why;
  EXPECT_THROW(SparseCholesky{options}, ConfigError);
  options.spare_capacity = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(options.Check(&why));
}

}  // namespace
}  // namespace ieslam
