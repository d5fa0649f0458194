// A run's files, from a run on the 9 real frames of tum-fr1-desk-9 (with ground truth).
#include "selection/pipeline/run_outputs.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "backend/ba_problem_io.h"
#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/calibration.h"
#include "core/trajectory.h"
#include "test_files.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

using testing_files::ReadFile;

const std::string kDesk = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";

class RunOutputsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    out_ = fs::temp_directory_path() /
           ("ieslam_run_outputs_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(out_);
  }
  void TearDown() override { fs::remove_all(out_); }

  RunResult RunAndWrite(const RunOptions& options) {
    const auto dataset = OpenDataset(options.dataset, options.dataset_options);
    RunResult run = RunOnDataset(*dataset, options);
    WriteRunOutputs(out_.string(), *dataset, options, run);
    return run;
  }
  static RunOptions Options() {
    RunOptions options;
    options.dataset = kDesk;
    options.threads = 1;
    return options;
  }
  fs::path out_;
};

TEST_F(RunOutputsTest, WritesEveryFileOfTheRun) {
  RunOptions options = Options();
  options.pipeline.refine = true;
  const RunResult run = RunAndWrite(options);
  for (const char* file :
       {"keyframes.tum", "trajectory.tum", "groundtruth.tum", "map.ply", "selected_frames.txt",
        "ba_problem.txt", "information_blocks.txt", "refined.tum", "report.json"}) {
    EXPECT_TRUE(fs::is_regular_file(out_ / file)) << file;
  }
  for (const auto& entry : fs::directory_iterator(out_)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  }
  EXPECT_EQ(ReadTumTrajectory((out_ / "keyframes.tum").string()).size(), run.keyframes.size());
  EXPECT_EQ(ReadTumTrajectory((out_ / "trajectory.tum").string()).size(), run.trajectory.size());
  EXPECT_EQ(ReadTumTrajectory((out_ / "refined.tum").string()).size(), run.keyframes.size());
  // selected_frames.txt: a line per selected frame, `index timestamp`.
  std::istringstream selected(ReadFile(out_ / "selected_frames.txt"));
  std::string line;
  size_t lines = 0;
  while (std::getline(selected, line)) ++lines;
  EXPECT_EQ(lines, run.pipeline.selection.selected.size());
  // The stored problem reads back as the run's.
  const StoredBaProblem stored = ReadBaProblem((out_ / "ba_problem.txt").string());
  EXPECT_EQ(stored.problem.T_w_c.size(), run.pipeline.problem.T_w_c.size());
  EXPECT_EQ(stored.problem.observations.size(), run.pipeline.problem.observations.size());
  EXPECT_EQ(stored.timestamps, run.timestamps);
  const std::string blocks = ReadFile(out_ / "information_blocks.txt");
  const size_t kinds = blocks.find("\nblocks ");
  ASSERT_NE(kinds, std::string::npos) << blocks.substr(0, 200);
  const std::string letters = blocks.substr(kinds + 8, blocks.find('\n', kinds + 1) - kinds - 8);
  EXPECT_EQ(std::count(letters.begin(), letters.end(), 'P'), run.pipeline.filter->num_poses());
  EXPECT_EQ(std::count(letters.begin(), letters.end(), 'F'), run.pipeline.filter->num_features());
  EXPECT_EQ(ReadFile(out_ / "map.ply").rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  // The report's ATE is what `ieslam evaluate` computes from the written files.
  const AteResult evaluated = ComputeAte(
      ReadTumTrajectoryForEvaluation((out_ / "groundtruth.tum").string()),
      ReadTumTrajectoryForEvaluation((out_ / "refined.tum").string()), EvaluationOptions());
  EXPECT_EQ(evaluated.translation.rmse, run.ate_refined_m);
}

TEST_F(RunOutputsTest, WithoutRefinementOrMapThoseFilesAreNotWritten) {
  RunOptions options = Options();
  options.build_map = false;
  RunAndWrite(options);
  EXPECT_TRUE(fs::is_regular_file(out_ / "report.json"));
  EXPECT_TRUE(fs::is_regular_file(out_ / "ba_problem.txt"));
  EXPECT_FALSE(fs::exists(out_ / "refined.tum"));
  EXPECT_FALSE(fs::exists(out_ / "map.ply"));
  const std::string report = ReadFile(out_ / "report.json");
  EXPECT_EQ(report.find("\"filter_vs_smoother\""), std::string::npos);
}

TEST_F(RunOutputsTest, DeadReckoningWritesNoProblem) {
  RunOptions options = Options();
  options.pipeline.selector.kind = SelectorKind::kDeadReckoning;
  const RunResult run = RunAndWrite(options);
  EXPECT_FALSE(run.pipeline.has_estimate);
  EXPECT_TRUE(fs::is_regular_file(out_ / "trajectory.tum"));
  EXPECT_FALSE(fs::exists(out_ / "ba_problem.txt"));
  EXPECT_FALSE(fs::exists(out_ / "information_blocks.txt"));
  EXPECT_EQ(ReadFile(out_ / "report.json").find("\"keyframe_sigmas\""), std::string::npos);
}

// The directory holds one run's set: an earlier run's files this one does not write go, a
// stale temp file of a writer that is gone goes, other files stay.
TEST_F(RunOutputsTest, AnEarlierRunsFilesThisRunDoesNotWriteAreRemoved) {
  RunOptions options = Options();
  options.build_map = false;
  for (const char* name :
       {"report.json", "refined.tum", "map.ply", "refine_report.json", "notes.txt"}) {
    std::ofstream(out_ / name) << "an earlier run's\n";
  }
  // No process has a pid above the kernel's pid_max (at most 2^22).
  std::ofstream(out_ / "map.ply.tmp.99999999") << "cut short\n";
  std::ofstream(out_ / "map.ply.tmp.x") << "not ours\n";
  const std::string alive = "trajectory.tum.tmp." + std::to_string(::getppid());
  std::ofstream(out_ / alive) << "another run's, still writing\n";
  RunAndWrite(options);
  EXPECT_TRUE(fs::is_regular_file(out_ / "report.json"));
  EXPECT_FALSE(fs::exists(out_ / "refined.tum"));
  EXPECT_FALSE(fs::exists(out_ / "map.ply"));
  EXPECT_FALSE(fs::exists(out_ / "refine_report.json"));
  EXPECT_FALSE(fs::exists(out_ / "map.ply.tmp.99999999"));
  EXPECT_TRUE(fs::exists(out_ / "notes.txt"));
  EXPECT_TRUE(fs::exists(out_ / "map.ply.tmp.x"));
  EXPECT_TRUE(fs::exists(out_ / alive));
}

// In a directory that held no run, files of the run's names it does not write are the user's.
TEST_F(RunOutputsTest, ADirectoryThatHeldNoRunKeepsItsFiles) {
  RunOptions options = Options();
  options.build_map = false;
  std::ofstream(out_ / "map.ply") << "the user's\n";
  RunAndWrite(options);
  EXPECT_TRUE(fs::is_regular_file(out_ / "report.json"));
  EXPECT_EQ(ReadFile(out_ / "map.ply"), "the user's\n");
  EXPECT_TRUE(fs::exists(out_ / kRunOutputMarker));
  // The directory holds a run now: the next run clears what it does not write.
  RunAndWrite(options);
  EXPECT_FALSE(fs::exists(out_ / "map.ply"));
}

// A refinement that failed writes no refined.tum and says why in the report.
TEST_F(RunOutputsTest, AFailedRefinementIsReportedAndNotWrittenAsRefined) {
  RunOptions options = Options();
  options.build_map = false;
  options.pipeline.refine = true;
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  RunResult run = RunOnDataset(*dataset, options);
  ASSERT_TRUE(run.refined());
  // An earlier run's set in the same directory.
  std::ofstream(out_ / "report.json") << "an earlier run's\n";
  std::ofstream(out_ / "refined.tum") << "an earlier run's\n";
  run.pipeline.refinement->failure = "the bundle adjustment failed (FAILURE: test)";
  WriteRunOutputs(out_.string(), *dataset, options, run);
  EXPECT_FALSE(fs::exists(out_ / "refined.tum"));
  const std::string report = ReadFile(out_ / "report.json");
  EXPECT_NE(report.find("\"refinement_failed\": \"the bundle adjustment failed (FAILURE: test)\""),
            std::string::npos)
      << report;
}

// With the depth correction asked for, the run writes the dataset's calibration with it as
// corrected_calib.yaml, which reads back; a second pass that reads that very file, into the
// same directory, neither removes nor replaces it, and says so.
TEST_F(RunOutputsTest, TheCorrectedCalibrationIsWrittenButNeverOverTheOneInUse) {
  RunOptions options = Options();
  options.build_map = false;
  options.save_map = false;
  options.pipeline.refine = true;
  options.pipeline.ba.estimate_depth_correction = true;
  const RunResult first = RunAndWrite(options);
  ASSERT_TRUE(first.refined());
  ASSERT_TRUE(first.corrected_calibration.has_value());
  const fs::path written = out_ / "corrected_calib.yaml";
  ASSERT_TRUE(fs::is_regular_file(written));
  const Rig back = ReadCalibration(written.string());
  EXPECT_EQ(back.range.depth_correction, first.corrected_calibration->range.depth_correction);
  EXPECT_TRUE(back.range.HasDepthCorrection());

  const std::string before = ReadFile(written);
  options.dataset_options.calib_file = written.string();
  const RunResult second = RunAndWrite(options);
  ASSERT_TRUE(second.corrected_calibration.has_value());
  EXPECT_EQ(ReadFile(written), before);
  EXPECT_NE(ReadFile(out_ / "report.json").find("is the calibration this run read"),
            std::string::npos);
  // Without the estimate, the same pass into the same directory still keeps it.
  options.pipeline.ba.estimate_depth_correction = false;
  RunAndWrite(options);
  EXPECT_EQ(ReadFile(written), before);
  // A run that reads another calibration clears an earlier run's corrected_calib.yaml.
  options.dataset_options.calib_file.clear();
  RunAndWrite(options);
  EXPECT_FALSE(fs::exists(written));
}

TEST_F(RunOutputsTest, AStopWhileWritingIsReportedAsInterrupted) {
  RunOptions options = Options();
  options.build_map = false;
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  const RunResult run = RunOnDataset(*dataset, options);
  ASSERT_FALSE(run.interrupted());
  WriteRunOutputs(out_.string(), *dataset, options, run, [] { return true; });
  EXPECT_NE(ReadFile(out_ / "report.json").find("\"interrupted\": true"), std::string::npos);
}

}  // namespace
}  // namespace ieslam
