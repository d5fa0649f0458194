#include "backend/dense_then_sparse_factor.h"

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "backend/upper_column_storage.h"

namespace ieslam {
namespace {

// A factor that writes each call into a shared log ("<name> <call>") and answers
// AddAndSolve from a script (kOk when it runs out).
class ScriptedFactor final : public InformationFactor {
 public:
  ScriptedFactor(std::string name, bool dense, std::vector<std::string>* log,
                 std::deque<FactorStatus> script = {})
      : name_(std::move(name)), dense_(dense), log_(log), script_(std::move(script)) {}

  FactorStatus AddAndSolve(const UpperColumnStorage& /*matrix*/, const InformationUpdate& update,
                           bool keep_exact, const Eigen::VectorXd& /*info_vector*/,
                           const Eigen::VectorXd& /*guess*/, Eigen::VectorXd* state) override {
    Log("add " + std::to_string(update.old_dim) + (keep_exact ? " exact" : " may be inexact"));
    *state = Eigen::VectorXd::Constant(1, dense_ ? 1.0 : 2.0);
    if (script_.empty()) return FactorStatus::kOk;
    const FactorStatus status = script_.front();
    script_.pop_front();
    return status;
  }
  void AddDeferred(const UpperColumnStorage& /*matrix*/, const InformationUpdate& update) override {
    Log("defer " + std::to_string(update.old_dim));
  }
  void Restore(const UpperColumnStorage& /*matrix*/, bool factored) override {
    Log(factored ? "restore factored" : "restore");
  }
  bool Refactor(const UpperColumnStorage& /*matrix*/) override {
    Log("refactor");
    return true;
  }
  void MakeExact() override { Log("make exact"); }
  Eigen::VectorXd Solve(const Eigen::VectorXd& info_vector) const override {
    Log("solve");
    return info_vector;
  }
  double LogDet() const override { return dense_ ? 1.0 : 2.0; }
  Eigen::MatrixXd InverseSubmatrix(const std::vector<int>& indices) const override {
    return Eigen::MatrixXd::Zero(indices.size(), indices.size());
  }
  int64_t FactorNonzeros() const override { return dense_ ? 10 : 20; }
  const FactorTimings& timings() const override { return timings_; }
  bool uses_pose_schur() const override { return dense_; }

 private:
  void Log(const std::string& call) const { log_->push_back(name_ + " " + call); }

  std::string name_;
  bool dense_;
  std::vector<std::string>* log_;
  std::deque<FactorStatus> script_;
  FactorTimings timings_;
};

class DenseThenSparseFactorTest : public ::testing::Test {
 protected:
  // A policy switching past `max_dense_pose_dim`; the dense factor answers `dense_script`.
  std::unique_ptr<DenseThenSparseFactor> MakePolicy(int max_dense_pose_dim,
                                                    std::deque<FactorStatus> dense_script = {}) {
    return std::make_unique<DenseThenSparseFactor>(
        max_dense_pose_dim,
        [this, dense_script]() {
          ++dense_made_;
          return std::make_unique<ScriptedFactor>("dense", true, &log_, dense_script);
        },
        [this]() {
          ++sparse_made_;
          return std::make_unique<ScriptedFactor>("sparse", false, &log_);
        });
  }

  // Adds a pose whose update starts at `old_dim`.
  FactorStatus Add(InformationFactor* factor, int old_dim, bool keep_exact = false) {
    InformationUpdate update;
    update.old_dim = old_dim;
    Eigen::VectorXd state;
    return factor->AddAndSolve(matrix_, update, keep_exact, Eigen::VectorXd(), Eigen::VectorXd(),
                               &state);
  }

  std::vector<std::string> log_;
  int dense_made_ = 0;
  int sparse_made_ = 0;
  UpperColumnStorage matrix_;
};

TEST_F(DenseThenSparseFactorTest, TheSparseFactorTakesOverPastTheDenseLimit) {
  const auto policy = MakePolicy(/*max_dense_pose_dim=*/12);  // two poses
  EXPECT_TRUE(policy->uses_pose_schur());
  EXPECT_EQ(Add(policy.get(), 0), FactorStatus::kOk);
  EXPECT_EQ(Add(policy.get(), 10), FactorStatus::kOk);
  EXPECT_TRUE(policy->uses_pose_schur());
  EXPECT_EQ(policy->LogDet(), 1.0);
  EXPECT_EQ(Add(policy.get(), 20), FactorStatus::kOk);
  EXPECT_FALSE(policy->uses_pose_schur());
  EXPECT_EQ(Add(policy.get(), 30), FactorStatus::kOk);
  EXPECT_EQ(policy->LogDet(), 2.0);
  EXPECT_EQ(policy->FactorNonzeros(), 20);
  EXPECT_EQ(dense_made_, 1);
  EXPECT_EQ(sparse_made_, 1);
  EXPECT_EQ(log_, (std::vector<std::string>{
                      "dense add 0 may be inexact", "dense add 10 may be inexact",
                      "sparse add 20 may be inexact", "sparse add 30 may be inexact"}));
}

TEST_F(DenseThenSparseFactorTest, BelowOnePoseTheSparseFactorDoesEverything) {
  const auto policy = MakePolicy(0);
  EXPECT_FALSE(policy->uses_pose_schur());
  EXPECT_EQ(dense_made_, 0);
  EXPECT_EQ(sparse_made_, 1);
}

// The dense factor cannot recover the state: the sparse one takes the same update over, and
// decides. A refusal by the dense one is passed on (and restored there).
TEST_F(DenseThenSparseFactorTest, AnUnsolvedUpdateIsHandedToTheSparseFactor) {
  const auto policy = MakePolicy(
      2400, {FactorStatus::kOk, FactorStatus::kNotPositiveDefinite, FactorStatus::kUnsolved});
  EXPECT_EQ(Add(policy.get(), 0), FactorStatus::kOk);
  EXPECT_EQ(Add(policy.get(), 10), FactorStatus::kNotPositiveDefinite);
  policy->Restore(matrix_, true);
  EXPECT_TRUE(policy->uses_pose_schur());
  EXPECT_EQ(Add(policy.get(), 10), FactorStatus::kOk);
  EXPECT_FALSE(policy->uses_pose_schur());
  EXPECT_EQ(log_,
            (std::vector<std::string>{"dense add 0 may be inexact", "dense add 10 may be inexact",
                                      "dense restore factored", "dense add 10 may be inexact",
                                      "sparse add 10 may be inexact"}));
}

// A query makes the factor exact; the next update then keeps it exact, and the one after
// may leave it inexact again. Asked to keep it exact, every update does.
TEST_F(DenseThenSparseFactorTest, AnUpdateAfterAQueryKeepsTheFactorExact) {
  const auto policy = MakePolicy(2400);
  Add(policy.get(), 0);
  policy->MakeExact();
  Add(policy.get(), 10);
  Add(policy.get(), 20);
  Add(policy.get(), 30, /*keep_exact=*/true);
  EXPECT_EQ(log_, (std::vector<std::string>{"dense add 0 may be inexact", "dense make exact",
                                            "dense add 10 exact", "dense add 20 may be inexact",
                                            "dense add 30 exact"}));
}

// Deferred updates count towards the limit too, and the rest goes to the active factor.
TEST_F(DenseThenSparseFactorTest, DeferredUpdatesCountTowardsTheLimit) {
  const auto policy = MakePolicy(12);
  for (const int old_dim : {0, 10, 20}) {
    InformationUpdate update;
    update.old_dim = old_dim;
    policy->AddDeferred(matrix_, update);
  }
  EXPECT_TRUE(policy->Refactor(matrix_));
  EXPECT_EQ(policy->Solve(Eigen::VectorXd::Ones(3)), Eigen::VectorXd::Ones(3));
  EXPECT_EQ(log_, (std::vector<std::string>{"dense defer 0", "dense defer 10", "sparse defer 20",
                                            "sparse refactor", "sparse solve"}));
}

}  // namespace
}  // namespace ieslam
