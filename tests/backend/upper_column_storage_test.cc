#include "backend/upper_column_storage.h"

#include <gtest/gtest.h>
#include <Eigen/Core>

namespace ieslam {
namespace {

// The symmetric 5x5 matrix the tests build: a 3x3 block (a feature), then a 2x2 block (a
// "pose") coupled to it, appended column by column as the filter appends them.
UpperColumnStorage MakeMatrix(Eigen::MatrixXd* dense) {
  *dense = Eigen::MatrixXd::Zero(5, 5);
  // clang-format off
  *dense << 4, 1, 2, 0.5, 0,
            1, 5, 3, 0,   0.25,
            2, 3, 6, 1,   0,
            0.5, 0, 1, 7, 2,
            0, 0.25, 0, 2, 8;
  // clang-format on
  UpperColumnStorage matrix;
  for (int k = 0; k < 5; ++k) {
    matrix.StartColumn();
    for (int r = 0; r <= k; ++r) {
      if ((*dense)(r, k) != 0.0 || r >= (k < 3 ? 0 : 3)) matrix.Append(r, (*dense)(r, k));
    }
  }
  return matrix;
}

TEST(UpperColumnStorageTest, AppendedColumnsHoldTheUpperTriangle) {
  Eigen::MatrixXd dense;
  const UpperColumnStorage matrix = MakeMatrix(&dense);
  EXPECT_EQ(matrix.dim(), 5);
  // The diagonal blocks' upper triangles (6 + 3 entries) and the 3 nonzero couplings.
  EXPECT_EQ(matrix.nonzeros(), 12);
  const Eigen::MatrixXd upper = Eigen::MatrixXd(matrix.Upper());
  EXPECT_EQ(upper, Eigen::MatrixXd(dense.triangularView<Eigen::Upper>()));
  EXPECT_EQ(Eigen::MatrixXd(matrix.Full()), dense);
}

TEST(UpperColumnStorageTest, DiagonalBlocksAreAddedReadAndRestored) {
  Eigen::MatrixXd dense;
  UpperColumnStorage matrix = MakeMatrix(&dense);
  const Eigen::MatrixXd saved = matrix.DiagonalBlock(0, 3);
  EXPECT_EQ(saved, dense.topLeftCorner(3, 3));
  Eigen::Matrix3d increment;
  increment << 1, 2, 3, 2, 4, 5, 3, 5, 6;
  matrix.AddToDiagonalBlock(0, increment);
  EXPECT_EQ(matrix.DiagonalBlock(0, 3), dense.topLeftCorner(3, 3) + increment);
  EXPECT_EQ(matrix.DiagonalBlock(3, 2), dense.bottomRightCorner(2, 2));  // untouched
  matrix.SetDiagonalBlock(0, saved);
  EXPECT_EQ(Eigen::MatrixXd(matrix.Full()), dense);
}

TEST(UpperColumnStorageTest, TruncateDropsTheLastColumns) {
  Eigen::MatrixXd dense;
  UpperColumnStorage matrix = MakeMatrix(&dense);
  matrix.Truncate(3);
  EXPECT_EQ(matrix.dim(), 3);
  EXPECT_EQ(matrix.nonzeros(), 6);
  EXPECT_EQ(Eigen::MatrixXd(matrix.Full()), dense.topLeftCorner(3, 3));
  // And it grows again from there.
  matrix.StartColumn();
  matrix.Append(3, 9.0);
  EXPECT_EQ(matrix.dim(), 4);
  EXPECT_EQ(Eigen::MatrixXd(matrix.Full())(3, 3), 9.0);
}

TEST(UpperColumnStorageTest, AddToEntryChangesOneStoredEntry) {
  Eigen::MatrixXd dense;
  UpperColumnStorage matrix = MakeMatrix(&dense);
  matrix.AddToEntry(2, 3, -0.5);  // a coupling, in the later column
  matrix.AddToEntry(4, 4, 1.0);   // a diagonal entry
  dense(2, 3) = dense(3, 2) = 0.5;
  dense(4, 4) = 9.0;
  EXPECT_EQ(Eigen::MatrixXd(matrix.Full()), dense);
  EXPECT_EQ(matrix.nonzeros(), 12);
}

}  // namespace
}  // namespace ieslam
