// SparseCholesky::InverseSubmatrix (backend/sparse_inverse.cc) against a dense inverse, on
// a factor grown in place (simplicial LDL^T, the path solved in column chunks) and on a
// one-shot supernodal factor, with more wanted variables than one chunk holds, asked in a
// scrambled order with a repeat.
#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "backend/sparse_information.h"

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

TEST(SparseInverseTest, ManyEntriesAgreeWithDenseInverse) {
  std::mt19937 rng(5);
  UpperColumnStorage matrix;
  Eigen::MatrixXd dense(0, 0);
  AppendRandomBlocks(60, &rng, &matrix, &dense);
  SparseCholesky incremental(FillReducingOrdering::kMetis, 1.0);
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
  SparseCholesky full(FillReducingOrdering::kAmd);
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

}  // namespace
}  // namespace ieslam
