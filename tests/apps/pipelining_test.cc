// Pipelining must not change the answer: `ieslam run` with prefetching worker threads
// writes the same trajectories as the sequential --threads 1 mode for the same seed.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "apps/run_pipeline.h"
#include "command_test_util.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;
using testing_apps::ReadFile;

TEST(PipeliningTest, ThreadedRunWritesTheSequentialTrajectory) {
  const fs::path root =
      fs::temp_directory_path() / ("ieslam_pipelining_test_" + std::to_string(::getpid()));
  SyntheticDatasetOptions synth;
  synth.frames = 20;
  synth.frames_per_loop = 300;
  synth.resolution_scale = 0.5;
  WriteSyntheticDataset((root / "synthetic").string(), synth);

  std::string trajectory[2], keyframes[2];
  int selected[2] = {0, 0};
  const int threads[2] = {1, 3};
  for (int k = 0; k < 2; ++k) {
    RunOptions options;
    options.dataset = (root / "synthetic").string();
    options.output = (root / ("out" + std::to_string(threads[k]))).string();
    options.threads = threads[k];
    options.seed = 7;
    options.quiet = true;
    options.write_map = false;
    const RunSummary summary = RunPipeline(options);
    selected[k] = summary.frames_selected;
    trajectory[k] = ReadFile(fs::path(options.output) / "trajectory.tum");
    keyframes[k] = ReadFile(fs::path(options.output) / "keyframes.tum");
    EXPECT_EQ(summary.frames_processed, 20) << "threads " << threads[k];
    EXPECT_LT(summary.ate_trajectory_m, 0.02) << "threads " << threads[k];
  }
  EXPECT_GT(selected[0], 1);
  EXPECT_EQ(selected[0], selected[1]);
  // Every processed frame has a line: the files are not trivially equal.
  EXPECT_GT(std::count(trajectory[0].begin(), trajectory[0].end(), '\n'), 20);
  EXPECT_EQ(trajectory[0], trajectory[1]);
  EXPECT_EQ(keyframes[0], keyframes[1]);
  fs::remove_all(root);
}

}  // namespace
}  // namespace ieslam
