// The whole run on a small synthetic sequence with exact ground truth, through the library:
// results in memory, then the files.
#include "selection/pipeline/dataset_run.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/calibration.h"
#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"
#include "global_shutter_calibration.h"
#include "selection/pipeline/run_outputs.h"
#include "test_files.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

using testing_files::ReadFile;

class DatasetRunTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_dataset_run_test_" + std::to_string(::getpid()));
    SyntheticDatasetOptions options;
    options.frames = 36;
    options.frames_per_loop = 300;  // hand-held motion: ~2 cm and ~1.5 deg per frame
    WriteSyntheticDataset((root_ / "synthetic").string(), options);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  static RunOptions Options(const std::string& dataset = "synthetic") {
    RunOptions options;
    options.dataset = (root_ / dataset).string();
    options.threads = 1;
    return options;
  }
  // Runs on the dataset and writes the outputs into root_/output.
  static RunResult Run(const RunOptions& options, const std::string& output,
                       const PipelineHooks& hooks = {}) {
    const auto dataset = OpenDataset(options.dataset, options.dataset_options);
    RunResult run = RunOnDataset(*dataset, options, hooks);
    fs::create_directories(root_ / output);
    WriteRunOutputs((root_ / output).string(), *dataset, options, run);
    return run;
  }
  static fs::path root_;
};
fs::path DatasetRunTest::root_;

TEST_F(DatasetRunTest, WritesEveryOutputAndTracksTheSyntheticSequence) {
  const RunResult run = Run(Options(), "out");
  const fs::path out = root_ / "out";
  for (const char* file : {"keyframes.tum", "trajectory.tum", "groundtruth.tum", "map.ply",
                           "selected_frames.txt", "report.json"}) {
    EXPECT_TRUE(fs::is_regular_file(out / file)) << file;
  }
  EXPECT_EQ(OpenDataset(Options().dataset, DatasetOptions())->size(), 36);
  EXPECT_LT(static_cast<int>(run.pipeline.selection.selected.size()), 36);
  EXPECT_TRUE(run.frames_skipped.empty());
  EXPECT_LT(run.ate_trajectory_m, 0.02);
  EXPECT_LT(run.ate_keyframes_m, 0.02);
  // The report's ATE is what `ieslam evaluate` computes from the written files.
  const EvaluationResult evaluated = EvaluateTrajectoryFiles(
      (out / "groundtruth.tum").string(), (out / "trajectory.tum").string(), EvaluationOptions());
  EXPECT_EQ(evaluated.ate.translation.rmse, run.ate_trajectory_m);
  const std::string report = ReadFile(out / "report.json");
  for (const char* key :
       {"\"version\"", "\"dataset\"", "\"seed\"", "\"options\"", "\"frames_total\"",
        "\"frames_selected\"", "\"frames_skipped\"", "\"state_dim\"", "\"poses\"", "\"features\"",
        "\"interrupted\"", "\"seconds\"", "\"frontend\"", "\"selection\"", "\"filter\"",
        "\"ate_rmse_m\"", "\"keyframes\"", "\"trajectory\""}) {
    EXPECT_NE(report.find(key), std::string::npos) << key;
  }
  const std::string ply = ReadFile(out / "map.ply");
  EXPECT_EQ(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(ply.find("element vertex "), std::string::npos);
}

// A stop after the last frame (Ctrl-C while refining) is not dropped: the run is interrupted,
// its refinement is no refinement, and neither is written as refined.
TEST_F(DatasetRunTest, AStopAfterTheLastFrameInterruptsTheRefinement) {
  RunOptions options = Options();
  options.pipeline.refine = true;
  // Selection polls before each candidate: once it has looked at its last one, every further
  // poll is the refinement's or the map's.
  int polls = 0, selection_polls = 0;
  {
    PipelineHooks count;
    count.stop = [&selection_polls] { return ++selection_polls < 0; };
    RunOptions no_refine = Options();
    no_refine.build_map = false;
    Run(no_refine, "counting_polls", count);
  }
  PipelineHooks hooks;
  hooks.stop = [&polls, selection_polls] { return ++polls > selection_polls; };
  const RunResult run = Run(options, "stopped_refining", hooks);
  EXPECT_EQ(run.frames_processed(), 36);
  EXPECT_FALSE(run.pipeline.selection.interrupted);
  EXPECT_TRUE(run.interrupted());
  ASSERT_TRUE(run.pipeline.refinement);
  EXPECT_FALSE(run.refined());
  EXPECT_NE(run.pipeline.refinement->failure.find("interrupted"), std::string::npos);
  EXPECT_LT(run.ate_refined_m, 0.0);
  const fs::path out = root_ / "stopped_refining";
  EXPECT_FALSE(fs::exists(out / "refined.tum"));
  const std::string report = ReadFile(out / "report.json");
  EXPECT_NE(report.find("\"interrupted\": true"), std::string::npos);
  EXPECT_NE(report.find("\"refinement_failed\""), std::string::npos);
}

TEST_F(DatasetRunTest, StopRequestEndsTheRunAndStillWritesItsOutputs) {
  int polls = 0;
  PipelineHooks hooks;
  hooks.stop = [&polls] { return ++polls > 4; };
  const RunResult run = Run(Options(), "stopped", hooks);
  EXPECT_TRUE(run.interrupted());
  EXPECT_GT(run.frames_processed(), 1);
  EXPECT_LT(run.frames_processed(), 36);
  const std::string report = ReadFile(root_ / "stopped" / "report.json");
  EXPECT_NE(report.find("\"interrupted\": true"), std::string::npos);
  // Frames the run never reached are not reported as skipped.
  EXPECT_TRUE(run.frames_skipped.empty());
  EXPECT_TRUE(fs::is_regular_file(root_ / "stopped" / "trajectory.tum"));
}

// A stop the selection obeyed ends the selection only, though the request stays raised: the
// frames it processed are still mapped and refined.
TEST_F(DatasetRunTest, AStopDuringSelectionStillMapsAndRefinesWhatWasProcessed) {
  RunOptions options = Options();
  options.pipeline.refine = true;
  int polls = 0;
  PipelineHooks hooks;
  hooks.stop = [&polls] { return ++polls > 8; };
  const RunResult run = Run(options, "stopped_selecting", hooks);
  EXPECT_TRUE(run.pipeline.selection.interrupted);
  EXPECT_LT(run.frames_processed(), 36);
  EXPECT_TRUE(run.refined()) << (run.pipeline.refinement ? run.pipeline.refinement->failure : "");
  ASSERT_TRUE(run.map.has_value());
  EXPECT_GT(run.map->size(), 0u);
  EXPECT_TRUE(fs::is_regular_file(root_ / "stopped_selecting" / "refined.tum"));
}

// The same sequence with frames [first, last) cut out: a jump the front end must recover from.
void WriteWithGap(const fs::path& source, const fs::path& target, int first, int last) {
  fs::create_directories(target);
  fs::copy_file(source / "calib.yaml", target / "calib.yaml", fs::copy_options::overwrite_existing);
  fs::copy_file(source / "groundtruth.txt", target / "groundtruth.txt",
                fs::copy_options::overwrite_existing);
  for (const char* list : {"rgb.txt", "depth.txt"}) {
    std::ifstream in(source / list);
    std::ofstream out(target / list);
    std::string line;
    int frame = 0;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      std::string stamp, path;
      fields >> stamp >> path;
      if (frame < first || frame >= last) out << stamp << " " << (source / path).string() << "\n";
      ++frame;
    }
  }
}

TEST_F(DatasetRunTest, AJumpInTheSequenceIsBridgedAndStaysInTheSameFrame) {
  WriteWithGap(root_ / "synthetic", root_ / "gap", 12, 20);  // ~16 cm and ~12 deg in one step
  const RunResult run = Run(Options("gap"), "gap_out");
  EXPECT_EQ(static_cast<int>(run.pipeline.T_w_c.size()), 28);
  EXPECT_TRUE(run.frames_skipped.empty());
  // One rigid alignment fits the frames before and after the jump alike.
  EXPECT_LT(run.ate_trajectory_m, 0.02);
}

// Pipelining must not change the answer: with prefetching worker threads (and the map's
// frames loaded on them) the run gives the same trajectories and map as the sequential
// --threads 1 mode for the same seed.
TEST_F(DatasetRunTest, ThreadedRunGivesTheSequentialTrajectory) {
  Trajectory trajectory[2], keyframes[2];
  std::string maps[2];
  const int threads[2] = {1, 3};
  for (int k = 0; k < 2; ++k) {
    RunOptions options = Options();
    options.dataset_options.last = 19;
    options.threads = threads[k];
    options.seed = 7;
    const auto dataset = OpenDataset(options.dataset, options.dataset_options);
    const RunResult run = RunOnDataset(*dataset, options);
    trajectory[k] = run.trajectory;
    keyframes[k] = run.keyframes;
    EXPECT_EQ(run.frames_processed(), 20) << "threads " << threads[k];
    EXPECT_LT(run.ate_trajectory_m, 0.02) << "threads " << threads[k];
    ASSERT_TRUE(run.map.has_value());
    EXPECT_GT(run.map->size(), 1000u);
    const std::string ply =
        ::testing::TempDir() + "/threaded_run_map_" + std::to_string(threads[k]) + ".ply";
    run.map->WritePly(ply);
    std::ifstream in(ply, std::ios::binary);
    maps[k].assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    std::remove(ply.c_str());
  }
  EXPECT_EQ(maps[0], maps[1]);
  EXPECT_GT(keyframes[0].size(), 1u);
  ASSERT_EQ(trajectory[0].size(), 20u);
  ASSERT_EQ(trajectory[1].size(), trajectory[0].size());
  ASSERT_EQ(keyframes[1].size(), keyframes[0].size());
  for (size_t i = 0; i < trajectory[0].size(); ++i) {
    EXPECT_EQ(trajectory[0][i].timestamp, trajectory[1][i].timestamp);
    EXPECT_EQ(trajectory[0][i].T_w_c.matrix(), trajectory[1][i].T_w_c.matrix()) << i;
  }
  for (size_t i = 0; i < keyframes[0].size(); ++i) {
    EXPECT_EQ(keyframes[0][i].T_w_c.matrix(), keyframes[1][i].T_w_c.matrix()) << i;
  }
}

// Everything the run reports is in the result: the estimate with a covariance per keyframe,
// the refinement with --refine, each selected frame's cloud in the map once.
TEST_F(DatasetRunTest, TheResultHoldsTheEstimateAndTheRefinement) {
  RunOptions options = Options();
  options.dataset_options.last = 15;
  options.pipeline.refine = true;
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  const RunResult run = RunOnDataset(*dataset, options);
  const PipelineResult& p = run.pipeline;
  ASSERT_TRUE(p.has_estimate);
  EXPECT_EQ(p.estimate.poses.size(), p.selection.selected.size());
  EXPECT_EQ(p.estimate.pose_covariances.size(), p.selection.selected.size());
  EXPECT_EQ(static_cast<int>(p.estimate.features.size()), p.filter->num_features());
  ASSERT_TRUE(p.refinement.has_value());
  EXPECT_TRUE(p.refinement->smoothed.usable);
  EXPECT_TRUE(p.refinement->depth_alignment_tried);
  EXPECT_EQ(p.refinement->depth_frames, static_cast<int>(p.selection.selected.size()));
  EXPECT_GE(run.ate_refined_m, 0.0);
  EXPECT_LT(run.ate_refined_m, 0.02);
  ASSERT_TRUE(run.map.has_value());
  EXPECT_GT(run.map->size(), 1000u);
  EXPECT_TRUE(run.warnings.empty());
}

TEST_F(DatasetRunTest, OptionsAreChecked) {
  RunOptions options = Options();
  options.pipeline.refine = true;
  options.pipeline.selector.kind = SelectorKind::kDeadReckoning;
  const auto dataset = OpenDataset(options.dataset, options.dataset_options);
  EXPECT_THROW(RunOnDataset(*dataset, options), ConfigError);
}

// A rolling-shutter camera: compensated (the calibration's readout), the run tracks the
// sequence as a global shutter's and its stated covariance holds; read as a global shutter,
// every frame is a sheared view and the estimate drifts beyond what it states.
TEST(DatasetRunRollingShutterTest, CompensationKeepsTheEstimateAndItsCovarianceRight) {
  const fs::path root =
      fs::temp_directory_path() / ("ieslam_dataset_run_rs_test_" + std::to_string(::getpid()));
  SyntheticDatasetOptions synth;
  synth.frames = 60;
  synth.frames_per_loop = 200;  // ~65 deg/s
  synth.readout_s = 0.03;
  synth.scene.seed = 3;
  WriteSyntheticDataset((root / "rs").string(), synth);

  RunOptions options;
  options.dataset = (root / "rs").string();
  options.threads = 1;
  options.build_map = false;
  options.save_map = false;
  const RunResult compensated =
      RunOnDataset(*OpenDataset(options.dataset, options.dataset_options), options);
  options.dataset_options.calib_file =
      testing_files::WriteGlobalShutterCalibration(root / "rs", root / "global.yaml");
  const RunResult sheared =
      RunOnDataset(*OpenDataset(options.dataset, options.dataset_options), options);
  fs::remove_all(root);

  ASSERT_TRUE(compensated.velocity_counts);
  EXPECT_EQ(compensated.velocity_counts->none, 0);
  EXPECT_FALSE(sheared.velocity_counts);
  ASSERT_TRUE(compensated.consistency_filter && sheared.consistency_filter);
  EXPECT_LT(compensated.ate_trajectory_m, 0.6 * sheared.ate_trajectory_m);
  EXPECT_GT(compensated.consistency_filter->inside_2sigma, 0.9);
  // The mean NEES's band is a yardstick (consistency.h): the compensated run stays near it,
  // the sheared one is far above.
  const double upper = compensated.consistency_filter->nees_band.second;
  EXPECT_LT(compensated.consistency_filter->mean_nees, 2.0 * upper);
  EXPECT_GT(sheared.consistency_filter->mean_nees, 4.0 * upper);
  std::cout << "ATE " << compensated.ate_trajectory_m << " vs " << sheared.ate_trajectory_m
            << ", inside 2 sigma " << compensated.consistency_filter->inside_2sigma << " vs "
            << sheared.consistency_filter->inside_2sigma << ", NEES "
            << compensated.consistency_filter->mean_nees << " vs "
            << sheared.consistency_filter->mean_nees << " (band up to " << upper << ")\n";
}

// A range imager whose depth is tilted (a planted depth correction): read with a calibration
// that does not know it, the run drifts; its refinement estimates the correction, and the
// calibration it writes brings a second run back to the one that knew it. Applied in the
// refinement itself (with the clouds' alignment), it brings the refinement back in one pass.
TEST(DatasetRunDepthCorrectionTest, TheRefinementFindsAPlantedCorrectionAndASecondPassUsesIt) {
  const fs::path root =
      fs::temp_directory_path() / ("ieslam_dataset_run_dc_test_" + std::to_string(::getpid()));
  SyntheticDatasetOptions synth;
  synth.frames = 90;
  synth.frames_per_loop = 300;
  synth.depth_correction = {-0.02, 0.01, 0.015};
  synth.scene.seed = 3;
  WriteSyntheticDataset((root / "dc").string(), synth);
  Rig unaware = ReadCalibration((root / "dc" / "calib.yaml").string());
  unaware.range.depth_correction = {0.0, 0.0, 0.0};
  WriteCalibration((root / "unaware.yaml").string(), unaware);

  RunOptions options;
  options.dataset = (root / "dc").string();
  options.threads = 1;
  options.build_map = false;
  options.save_map = false;
  options.pipeline.refine = true;
  options.pipeline.depth_alignment.rounds = 0;
  const RunResult knowing =
      RunOnDataset(*OpenDataset(options.dataset, options.dataset_options), options);
  options.dataset_options.calib_file = (root / "unaware.yaml").string();
  options.pipeline.ba.estimate_depth_correction = true;
  const RunResult first =
      RunOnDataset(*OpenDataset(options.dataset, options.dataset_options), options);
  ASSERT_TRUE(first.corrected_calibration.has_value());
  WriteCalibration((root / "estimated.yaml").string(), *first.corrected_calibration);
  options.dataset_options.calib_file = (root / "estimated.yaml").string();
  options.pipeline.ba.estimate_depth_correction = false;
  const RunResult second =
      RunOnDataset(*OpenDataset(options.dataset, options.dataset_options), options);
  options.dataset_options.calib_file = (root / "unaware.yaml").string();
  options.pipeline.ba.estimate_depth_correction = true;
  options.pipeline.ba.apply_depth_correction = true;
  options.pipeline.depth_alignment.rounds = 1;
  const RunResult one_pass =
      RunOnDataset(*OpenDataset(options.dataset, options.dataset_options), options);
  fs::remove_all(root);

  const DepthCorrectionEstimate& estimate = first.pipeline.refinement->depth_correction;
  ASSERT_TRUE(estimate.usable) << estimate.failure;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(estimate.coefficients[i], synth.depth_correction[i], 0.003) << i;
  }
  EXPECT_GT(2.0 * (estimate.cost_without - estimate.cost_with), 100.0);
  EXPECT_GT(first.ate_trajectory_m, 2.0 * knowing.ate_trajectory_m);
  EXPECT_LT(second.ate_trajectory_m, 1.5 * knowing.ate_trajectory_m);
  std::cout << "ATE knowing " << knowing.ate_trajectory_m << ", unaware " << first.ate_trajectory_m
            << ", second pass " << second.ate_trajectory_m << "; estimate "
            << estimate.coefficients[0] << " " << estimate.coefficients[1] << " "
            << estimate.coefficients[2] << "\n";

  const Refinement& applied = *one_pass.pipeline.refinement;
  ASSERT_TRUE(applied.ok()) << applied.failure;
  ASSERT_NE(applied.corrected, nullptr);
  EXPECT_TRUE(applied.depth_alignment_used);
  EXPECT_TRUE(applied.corrected->depth_alignment_used);
  EXPECT_LT(one_pass.ate_refined_m, 0.5 * one_pass.ate_refined_uncorrected_m);
  EXPECT_LT(one_pass.ate_refined_m, 1.5 * knowing.ate_refined_m);
  std::cout << "refined ATE knowing " << knowing.ate_refined_m << ", one pass "
            << one_pass.ate_refined_m << " (without applying " << one_pass.ate_refined_uncorrected_m
            << ")\n";
}

}  // namespace
}  // namespace ieslam
