#include "backend/pose_schur_factor.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "backend/random_pose_problem.h"

namespace ieslam {
namespace {

// The random problem of random_pose_problem.h fed to a PoseSchurFactor.
struct RandomProblem : testing::RandomPoseProblem {
  explicit RandomProblem(unsigned seed) : RandomPoseProblem(seed) {}

  // Adds pose k; `factor` gets it with or without refactoring.
  bool AddPose(int k, PoseSchurFactor* factor, SchurUpdate update) {
    const testing::PoseAddition addition = Next(k);
    return factor->AddPose(addition.pose_offset, addition.I_pp, addition.observations, update);
  }

  void ExpectAgreement(const PoseSchurFactor& factor) {
    const Eigen::LLT<Eigen::MatrixXd> llt(I);
    ASSERT_EQ(llt.info(), Eigen::Success);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::VectorXd i(dim);
    for (int r = 0; r < dim; ++r) i[r] = uniform(rng);
    const Eigen::VectorXd x = llt.solve(i);
    EXPECT_LT((factor.Solve(i) - x).norm(), 1e-9 * x.norm());
    const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
    EXPECT_NEAR(factor.LogDet(), log_det, 1e-9 * std::abs(log_det));
    // A pose of the first loop, the newest pose and two features, scalars out of order.
    std::vector<int> indices = {pose_offsets.back() + 2, offset_of.begin()->second + 1};
    for (int c = 0; c < 6; ++c) indices.push_back(pose_offsets[1] + c);
    for (int c = 0; c < 3; ++c) indices.push_back(pose_offsets.back() - 3 + c);
    // Only the columns `indices` of the inverse: the whole inverse made this test take a
    // minute under the sanitizers.
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(dim, static_cast<int>(indices.size()));
    for (size_t c = 0; c < indices.size(); ++c) unit(indices[c], static_cast<int>(c)) = 1.0;
    const Eigen::MatrixXd expected = llt.solve(unit)(indices, Eigen::all);
    EXPECT_LT((factor.InverseSubmatrix(indices) - expected).norm(), 1e-9 * expected.norm());
  }
};

TEST(PoseSchurFactorTest, AgreesWithTheDenseFactorThroughEvictionsAndMoves) {
  for (const int prefetch : {0, 1, 4}) {
    for (const int evict_after : {1, 3, 100}) {
      SCOPED_TRACE(::testing::Message()
                   << "prefetch " << prefetch << ", evict_after " << evict_after);
      RandomProblem problem(prefetch * 10 + evict_after);
      PoseSchurFactor factor({prefetch, evict_after});
      for (int k = 0; k < 40; ++k) {
        ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kExact)) << "pose " << k;
        if (k % 7 == 3) {
          SCOPED_TRACE(::testing::Message() << "pose " << k);
          problem.ExpectAgreement(factor);
        }
      }
      problem.ExpectAgreement(factor);
    }
  }
}

TEST(PoseSchurFactorTest, DeferredAdditionsThenRefactorAgree) {
  RandomProblem problem(3);
  PoseSchurFactor factor({2, 3});
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kDefer));
  EXPECT_FALSE(factor.valid());
  ASSERT_TRUE(factor.Refactor());
  problem.ExpectAgreement(factor);
  for (int k = 20; k < 30; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kExact));
  problem.ExpectAgreement(factor);
}

// Many variables at once (more than one group of columns in InverseSubmatrix), first seen
// at very different times: every feature and a pose from each stretch, shuffled.
TEST(PoseSchurFactorTest, InverseOfManyVariablesFirstSeenAtDifferentTimes) {
  RandomProblem problem(7);
  PoseSchurFactor factor({2, 3});
  for (int k = 0; k < 40; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kExact));
  std::vector<int> indices;
  for (const auto& [feature, offset] : problem.offset_of) {
    for (int c = 0; c < 3; ++c) indices.push_back(offset + c);
  }
  for (const int k : {0, 13, 26, 39}) {
    for (int c = 0; c < 6; ++c) indices.push_back(problem.pose_offsets[k] + c);
  }
  std::shuffle(indices.begin(), indices.end(), problem.rng);
  ASSERT_GT(indices.size(), 150u);
  const int k = static_cast<int>(indices.size());
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(problem.dim, k);
  for (int c = 0; c < k; ++c) unit(indices[c], c) = 1.0;
  const Eigen::MatrixXd expected =
      Eigen::LLT<Eigen::MatrixXd>(problem.I).solve(unit)(indices, Eigen::all);
  const Eigen::MatrixXd inverse = factor.InverseSubmatrix(indices);
  EXPECT_LT((inverse - expected).norm(), 1e-9 * expected.norm());
  EXPECT_EQ(inverse, inverse.transpose());
}

// Lazy updates: the factor is a preconditioner between exact factorisations, and the state
// comes from conjugate gradients warm-started at the previous solution. Through the
// trajectory's returns (every pose re-observes features of poses long left) each solve
// agrees with the dense one, and the factor made exact agrees in full.
// The refactorisations there renew the float preconditioner (single_speedup 1e6: always
// when refactoring is due), or are exact in double (0).
TEST(PoseSchurFactorTest, LazyUpdatesSolveAsTheDenseFactorThroughReturns) {
  for (const auto& [evict_after, single_speedup] :
       std::vector<std::pair<int, double>>{{1, 2.0}, {3, 2.0}, {3, 1e6}, {3, 0.0}}) {
    SCOPED_TRACE(::testing::Message()
                 << "evict_after " << evict_after << ", single_speedup " << single_speedup);
    RandomProblem problem(40 + evict_after);
    PoseSchurFactor factor({2, evict_after, 1e-10, 60, 5.0, single_speedup});
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::VectorXd previous;
    int lazy = 0, iterations = 0;
    for (int k = 0; k < 60; ++k) {
      ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kLazy)) << "pose " << k;
      lazy += factor.exact() ? 0 : 1;
      Eigen::VectorXd i(problem.dim);
      for (int r = 0; r < problem.dim; ++r) i[r] = uniform(problem.rng);
      const Eigen::VectorXd x = Eigen::LLT<Eigen::MatrixXd>(problem.I).solve(i);
      Eigen::VectorXd guess = previous;
      guess.conservativeResize(problem.dim);
      guess.tail(problem.dim - previous.size()).setZero();
      Eigen::VectorXd solution;
      ASSERT_TRUE(factor.SolveIteratively(i, guess, &solution)) << "pose " << k;
      iterations += factor.last_cg_iterations();
      EXPECT_LT((solution - x).norm(), 1e-9 * x.norm()) << "pose " << k;
      previous = solution;
    }
    // Refactoring this small S is cheap, yet many updates are lazy (the cost rule).
    EXPECT_GT(lazy, 10);
    EXPECT_GT(iterations, 0);
    ASSERT_TRUE(factor.MakeExact());
    EXPECT_TRUE(factor.exact());
    problem.ExpectAgreement(factor);
    // And exact updates go on from there.
    for (int k = 60; k < 66; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kExact));
    problem.ExpectAgreement(factor);
  }
}

// A pose with no information makes the matrix singular: refused, and nothing changes.
TEST(PoseSchurFactorTest, AFailedAdditionLeavesTheFactorUnchanged) {
  RandomProblem problem(5);
  PoseSchurFactor factor({1, 2});
  for (int k = 0; k < 25; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kExact));
  const Eigen::VectorXd i = Eigen::VectorXd::LinSpaced(problem.dim, -1.0, 1.0);
  const Eigen::VectorXd before = factor.Solve(i);
  const double log_det = factor.LogDet();
  // Re-observes two features with a rank-deficient pose block: not positive definite.
  ObservationBlocks obs;
  obs.feature_offset = problem.offset_of.begin()->second;
  std::vector<ObservationBlocks> observations = {obs};
  EXPECT_FALSE(factor.AddPose(problem.dim, Eigen::Matrix<double, 6, 6>::Zero(), observations,
                              SchurUpdate::kExact));
  EXPECT_EQ(factor.num_poses(), 25);
  EXPECT_EQ((factor.Solve(i) - before).norm(), 0.0);
  EXPECT_EQ(factor.LogDet(), log_det);
  // And it goes on as if the failed pose had never come.
  for (int k = 25; k < 35; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kExact));
  problem.ExpectAgreement(factor);
}

// The same between lazy updates (cg_flop_weight 0: lazy whenever it may be): the singular
// pose is refused, and the solves go on as before.
TEST(PoseSchurFactorTest, ALazyAdditionThatIsNotPositiveDefiniteIsRefused) {
  RandomProblem problem(6);
  PoseSchurFactor factor({1, 2, 1e-10, 60, 0.0});
  for (int k = 0; k < 25; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kLazy));
  ASSERT_FALSE(factor.exact());
  const Eigen::VectorXd i = Eigen::VectorXd::LinSpaced(problem.dim, -1.0, 1.0);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(problem.dim);
  Eigen::VectorXd before, after;
  ASSERT_TRUE(factor.SolveIteratively(i, zero, &before));
  ObservationBlocks obs;
  obs.feature_offset = problem.offset_of.begin()->second;
  EXPECT_FALSE(
      factor.AddPose(problem.dim, Eigen::Matrix<double, 6, 6>::Zero(), {obs}, SchurUpdate::kLazy));
  EXPECT_EQ(factor.num_poses(), 25);
  ASSERT_TRUE(factor.SolveIteratively(i, zero, &after));
  EXPECT_EQ((after - before).norm(), 0.0);
  for (int k = 25; k < 35; ++k) ASSERT_TRUE(problem.AddPose(k, &factor, SchurUpdate::kLazy));
  ASSERT_TRUE(factor.MakeExact());
  problem.ExpectAgreement(factor);
}

}  // namespace
}  // namespace ieslam
