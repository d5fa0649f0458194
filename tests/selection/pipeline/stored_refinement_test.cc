// Refining a stored run later gives what the run's own refinement gave.
#include "selection/pipeline/stored_refinement.h"

#include <filesystem>
#include <utility>

#include <unistd.h>

#include <gtest/gtest.h>

#include "backend/ba_problem_io.h"
#include "core/error.h"
#include "core/file_util.h"
#include "selection/pipeline/dataset_run.h"
#include "selection/pipeline/run_outputs.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

const std::string kDesk = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";

class StoredRefinementTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    run_dir_ =
        fs::temp_directory_path() / ("ieslam_stored_refinement_test_" + std::to_string(::getpid()));
    fs::create_directories(run_dir_);
    RunOptions options;
    options.dataset = kDesk;
    options.threads = 1;
    options.pipeline.refine = true;
    options.build_map = false;
    dataset_ = OpenDataset(kDesk, options.dataset_options).release();
    run_ = new RunResult(RunOnDataset(*dataset_, options));
    WriteRunOutputs(run_dir_.string(), *dataset_, options, *run_);
  }
  static void TearDownTestSuite() {
    delete run_;
    delete dataset_;
    fs::remove_all(run_dir_);
  }
  static StoredRefinementOptions Options() {
    StoredRefinementOptions options;
    options.depth_alignment.num_threads = 1;
    return options;
  }
  static fs::path run_dir_;
  static Dataset* dataset_;
  static RunResult* run_;
};
fs::path StoredRefinementTest::run_dir_;
Dataset* StoredRefinementTest::dataset_ = nullptr;
RunResult* StoredRefinementTest::run_ = nullptr;

TEST_F(StoredRefinementTest, WithTheDatasetItEqualsTheRunsRefinement) {
  const StoredRefinement later = RefineStoredRun(run_dir_.string(), dataset_, Options());
  EXPECT_TRUE(later.aligned_clouds);
  // The observation gate refused some, so the refinement rests on the registered solve, which
  // the stored problem reproduces too.
  ASSERT_TRUE(run_->pipeline.refinement->registered_used);
  EXPECT_TRUE(later.refinement.registered_used);
  EXPECT_GT(later.refinement.refused, 0);
  EXPECT_EQ(later.refinement.refused, run_->pipeline.refinement->refused);
  EXPECT_EQ(later.refinement.refused_kept, run_->pipeline.refinement->refused_kept);
  const Trajectory now = RefinedTrajectory(*run_->pipeline.refinement, run_->timestamps);
  ASSERT_EQ(later.refined.size(), now.size());
  for (size_t i = 0; i < now.size(); ++i) {
    EXPECT_EQ(later.refined[i].timestamp, now[i].timestamp);
    EXPECT_EQ(later.refined[i].T_w_c.matrix(), now[i].T_w_c.matrix()) << i;
  }
  EXPECT_EQ(later.ate_refined_m, run_->ate_refined_m);
  EXPECT_EQ(later.ate_keyframes_m, run_->ate_keyframes_m);
  EXPECT_TRUE(later.warnings.empty());
}

TEST_F(StoredRefinementTest, WithoutTheDatasetItIsTheBundleAdjustment) {
  const StoredRefinement later = RefineStoredRun(run_dir_.string(), nullptr, Options());
  EXPECT_FALSE(later.aligned_clouds);
  EXPECT_FALSE(later.refinement.depth_alignment_tried);
  // The check's solve and the registered one, each as in the run (there without covariances:
  // the depth-aligned solve was the refinement).
  using Solves = std::pair<const BundleAdjustmentResult*, const BundleAdjustmentResult*>;
  const Refinement& run = *run_->pipeline.refinement;
  for (const auto& [now, then] : {Solves(&run.smoothed, &later.refinement.smoothed),
                                  Solves(&run.features(), &later.refinement.features())}) {
    ASSERT_EQ(then->T_w_c.size(), now->T_w_c.size());
    for (const auto& [frame, T] : now->T_w_c) {
      EXPECT_EQ(then->T_w_c.at(frame).matrix(), T.matrix()) << frame;
    }
  }
  EXPECT_EQ(&later.refinement.refined(), &later.refinement.registered);
}

TEST_F(StoredRefinementTest, StartedFromTheGroundTruthItMovesTheStart) {
  StoredRefinementOptions options = Options();
  options.from_ground_truth = true;
  const StoredRefinement from_gt = RefineStoredRun(run_dir_.string(), nullptr, options);
  const StoredRefinement from_run = RefineStoredRun(run_dir_.string(), nullptr, Options());
  EXPECT_NE(from_gt.refinement.smoothed.initial_cost, from_run.refinement.smoothed.initial_cost);
  EXPECT_GE(from_gt.ate_refined_m, 0.0);
}

TEST_F(StoredRefinementTest, BadInputsAreErrorsNamingThem) {
  const fs::path empty = run_dir_ / "empty";
  fs::create_directories(empty);
  try {
    RefineStoredRun(empty.string(), nullptr, Options());
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("ba_problem.txt"), std::string::npos) << e.what();
  }
  StoredRefinementOptions from_gt = Options();
  from_gt.from_ground_truth = true;
  fs::copy_file(run_dir_ / "ba_problem.txt", empty / "ba_problem.txt");
  try {
    RefineStoredRun(empty.string(), nullptr, from_gt);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("groundtruth.tum not found"), std::string::npos);
  }
  // Another camera: not the run's dataset.
  const auto other =
      OpenDataset(std::string(IESLAM_SHARED_DATA_DIR) + "/7scenes-dev", DatasetOptions());
  EXPECT_THROW(RefineStoredRun(run_dir_.string(), other.get(), Options()), DataError);
  StoredRefinementOptions bad = Options();
  bad.ba.max_iterations = 0;
  EXPECT_THROW(RefineStoredRun(run_dir_.string(), nullptr, bad), ConfigError);
}

// Nothing to adjust is no refinement: an error naming the file and why, not the run's poses
// passed off as refined.
TEST_F(StoredRefinementTest, AProblemWithoutObservationsIsADataError) {
  const fs::path dir = run_dir_ / "no_observations";
  fs::create_directories(dir);
  StoredBaProblem stored = ReadBaProblem((run_dir_ / "ba_problem.txt").string());
  stored.problem.observations.clear();
  WriteBaProblem((dir / "ba_problem.txt").string(), stored);
  try {
    RefineStoredRun(dir.string(), nullptr, Options());
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find((dir / "ba_problem.txt").string()), std::string::npos) << what;
    EXPECT_NE(what.find("no observations"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace ieslam
