// `ieslam run` and `ieslam refine` as a user runs them, on a small synthetic sequence with
// exact ground truth.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <csignal>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "command_test_util.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;
using testing_apps::ReadFile;

class CommandRunTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_command_run_test_" + std::to_string(::getpid()));
    SyntheticDatasetOptions options;
    options.frames = 36;
    options.frames_per_loop = 300;  // hand-held motion: ~2 cm and ~1.5 deg per frame
    WriteSyntheticDataset((root_ / "synthetic").string(), options);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }
  static fs::path root_;
};
fs::path CommandRunTest::root_;

// Two runs of the command, as a user makes them (separate processes: CHOLMOD's METIS keeps
// its random state across orderings within one process).
// --refine writes refined.tum and the comparison; `ieslam refine` on the run's
// ba_problem.txt and dataset later gives the same refined.tum, byte for byte. Without the
// dataset it is the bundle adjustment of the features alone, which the depth alignment
// improves on.
TEST_F(CommandRunTest, RefineNowAndRefineLaterFromTheStoredProblemAgree) {
  const fs::path out = root_ / "refined";
  const testing_apps::CommandResult run =
      testing_apps::RunIeslam("run --quiet --threads 1 --refine --dataset " +
                              (root_ / "synthetic").string() + " --output " + out.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  ASSERT_TRUE(fs::is_regular_file(out / "ba_problem.txt"));
  ASSERT_TRUE(fs::is_regular_file(out / "refined.tum"));
  const std::string gt = (out / "groundtruth.tum").string();
  const double ate_refined =
      EvaluateTrajectoryFiles(gt, (out / "refined.tum").string(), EvaluationOptions())
          .ate.translation.rmse;
  EXPECT_LT(ate_refined, 0.02);
  const std::string run_report = ReadFile(out / "report.json");
  EXPECT_NE(run_report.find("\"filter_vs_smoother\""), std::string::npos);
  std::smatch constraints;
  ASSERT_TRUE(std::regex_search(run_report, constraints, std::regex("\"constraints\": ([0-9]+)")))
      << run_report;
  EXPECT_GT(std::stoi(constraints[1]), 0);
  const fs::path later = root_ / "refined_later";
  const testing_apps::CommandResult later_run =
      testing_apps::RunIeslam("refine --run " + out.string() + " --dataset " +
                              (root_ / "synthetic").string() + " --output " + later.string());
  ASSERT_EQ(later_run.exit_code, 0) << later_run.output;
  EXPECT_EQ(ReadFile(later / "refined.tum"), ReadFile(out / "refined.tum"));
  const std::string report = ReadFile(later / "report.json");
  EXPECT_NE(report.find("\"refined\""), std::string::npos) << report;
  const fs::path features_only = root_ / "refined_features_only";
  const testing_apps::CommandResult features_run = testing_apps::RunIeslam(
      "refine --run " + out.string() + " --output " + features_only.string());
  ASSERT_EQ(features_run.exit_code, 0) << features_run.output;
  const double ate_features_only =
      EvaluateTrajectoryFiles(gt, (features_only / "refined.tum").string(), EvaluationOptions())
          .ate.translation.rmse;
  EXPECT_LT(ate_refined, ate_features_only);
  // Started from the ground truth instead, the features-only adjustment starts elsewhere (the
  // features placed from exact poses but noisy measurements) and ends at the same optimum.
  const fs::path from_gt = root_ / "refined_from_gt";
  const testing_apps::CommandResult gt_run = testing_apps::RunIeslam(
      "refine --run " + out.string() + " --from-ground-truth --output " + from_gt.string());
  ASSERT_EQ(gt_run.exit_code, 0) << gt_run.output;
  const auto cost = [](const std::string& report, const char* key) {
    std::smatch m;
    const std::regex pattern(std::string("\"") + key + "\": ([0-9.e+-]+)");
    return std::regex_search(report, m, pattern) ? std::stod(m[1]) : -1.0;
  };
  const std::string gt_report = ReadFile(from_gt / "report.json");
  const std::string run_start_report = ReadFile(features_only / "report.json");
  EXPECT_NE(gt_report.find("\"start\": \"ground_truth\""), std::string::npos);
  EXPECT_GT(std::abs(cost(gt_report, "initial_cost") - cost(run_start_report, "initial_cost")),
            0.1 * cost(run_start_report, "initial_cost"));
  EXPECT_NEAR(cost(gt_report, "final_cost"), cost(run_start_report, "final_cost"),
              1e-6 * cost(run_start_report, "final_cost"));
  const double ate_from_gt =
      EvaluateTrajectoryFiles(gt, (from_gt / "refined.tum").string(), EvaluationOptions())
          .ate.translation.rmse;
  EXPECT_NEAR(ate_from_gt, ate_features_only, 1e-5);
  const fs::path no_gt = root_ / "run_without_gt";
  fs::create_directories(no_gt);
  fs::copy_file(out / "ba_problem.txt", no_gt / "ba_problem.txt",
                fs::copy_options::overwrite_existing);
  const testing_apps::CommandResult without_gt = testing_apps::RunIeslam(
      "refine --run " + no_gt.string() + " --from-ground-truth --output " + no_gt.string());
  EXPECT_EQ(without_gt.exit_code, 3) << without_gt.output;
  EXPECT_NE(without_gt.output.find("groundtruth.tum not found"), std::string::npos)
      << without_gt.output;
  // Another dataset (another camera) is a data error naming it; --calib without --dataset,
  // a usage error.
  const std::string tum = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-fr1-desk-9";
  const testing_apps::CommandResult other =
      testing_apps::RunIeslam("refine --run " + out.string() + " --dataset " + tum + " --output " +
                              (root_ / "refined_other").string());
  EXPECT_EQ(other.exit_code, 3) << other.output;
  EXPECT_NE(other.output.find("not the run's"), std::string::npos) << other.output;
  const testing_apps::CommandResult calib_only =
      testing_apps::RunIeslam("refine --run " + out.string() + " --calib x.yaml --output " +
                              (root_ / "refined_other").string());
  EXPECT_EQ(calib_only.exit_code, 2) << calib_only.output;
  // A run directory without a stored problem is a data error (exit 3) naming the file.
  const testing_apps::CommandResult missing = testing_apps::RunIeslam(
      "refine --run " + later.string() + " --output " + (root_ / "x").string());
  EXPECT_EQ(missing.exit_code, 3) << missing.output;
  EXPECT_NE(missing.output.find("ba_problem.txt"), std::string::npos) << missing.output;
}

TEST_F(CommandRunTest, SingleThreadRunsAreByteIdentical) {
  const std::string dataset = (root_ / "synthetic").string();
  for (const char* out : {"a", "b"}) {
    const std::string command = std::string(IESLAM_BINARY) + " run --quiet --threads 1 --dataset " +
                                dataset + " --output " + (root_ / out).string() + " > /dev/null";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
  }
  for (const char* file : {"keyframes.tum", "trajectory.tum", "map.ply", "selected_frames.txt"}) {
    EXPECT_EQ(ReadFile(root_ / "a" / file), ReadFile(root_ / "b" / file)) << file;
  }
}

// A TUM sequence whose name names no camera runs with freiburg1's calibration, and says so.
TEST_F(CommandRunTest, AGuessedCalibrationIsAWarningOnStderrAndInTheReport) {
  const fs::path sequence = root_ / "unnamed_sequence";
  fs::create_directories(sequence);
  const fs::path tum = fs::path(IESLAM_SHARED_DATA_DIR) / "tum-fr1-desk-9";
  for (const char* name : {"rgb", "depth", "rgb.txt", "depth.txt", "groundtruth.txt"}) {
    fs::create_symlink(tum / name, sequence / name);
  }
  const fs::path out = root_ / "unnamed_out";
  const testing_apps::CommandResult r = testing_apps::RunIeslam(
      "run --quiet --last 2 --dataset " + sequence.string() + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string warning = "the directory name 'unnamed_sequence' names no TUM camera";
  EXPECT_NE(r.output.find("run: warning: " + warning), std::string::npos) << r.output;
  const std::string report = ReadFile(out / "report.json");
  EXPECT_NE(report.find("\"chosen_by\": \"fallback\""), std::string::npos)
      << report.substr(0, 2000);
  const size_t warnings = report.find("\"warnings\": [");
  ASSERT_NE(warnings, std::string::npos) << report.substr(0, 2000);
  EXPECT_NE(report.find(warning, warnings), std::string::npos) << report.substr(0, 2000);
}

// A map of the first half, then --map over the second half: one map of both, whose outputs
// hold the map's keyframes first and the second half's frames after them; a map that is not
// there is exit 3 naming its file, dead reckoning exit 2.
TEST_F(CommandRunTest, MapOnFromASavedMapIntoOneMapOfBothHalves) {
  const std::string dataset = (root_ / "synthetic").string();
  const fs::path first = root_ / "first_half", second = root_ / "second_half";
  const testing_apps::CommandResult mapped = testing_apps::RunIeslam(
      "run --quiet --threads 1 --last 17 --dataset " + dataset + " --output " + first.string());
  ASSERT_EQ(mapped.exit_code, 0) << mapped.output;
  const testing_apps::CommandResult continued =
      testing_apps::RunIeslam("run --quiet --threads 1 --first 18 --map " + first.string() +
                              " --dataset " + dataset + " --output " + second.string());
  ASSERT_EQ(continued.exit_code, 0) << continued.output;
  // The map's dataset is where the map says: its frames are in map.ply too, which holds more
  // than the second half's own.
  EXPECT_EQ(continued.output.find("left out"), std::string::npos) << continued.output;
  const fs::path alone = root_ / "second_half_alone";
  const testing_apps::CommandResult second_only = testing_apps::RunIeslam(
      "run --quiet --threads 1 --first 18 --dataset " + dataset + " --output " + alone.string());
  ASSERT_EQ(second_only.exit_code, 0) << second_only.output;
  const auto vertices = [](const fs::path& ply) {
    std::smatch v;
    const std::string header = ReadFile(ply).substr(0, 400);
    return std::regex_search(header, v, std::regex("element vertex (\\d+)")) ? std::stol(v[1])
                                                                             : -1L;
  };
  EXPECT_GT(vertices(second / "map.ply"), vertices(alone / "map.ply"));
  EXPECT_GT(vertices(alone / "map.ply"), 0);
  const std::string first_report = ReadFile(first / "report.json");
  const std::string report = ReadFile(second / "report.json");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(first_report, m, std::regex("\"frames_selected\": (\\d+)")));
  const int map_keyframes = std::stoi(m[1]);
  ASSERT_TRUE(std::regex_search(
      report, m,
      std::regex(
          "\"continued_map\": \\{[^}]*\"keyframes\": (\\d+)[^}]*\"dataset_frames\": (\\d+)")))
      << report.substr(0, 3000);
  EXPECT_EQ(std::stoi(m[1]), map_keyframes);
  EXPECT_EQ(std::stoi(m[2]), 18);
  ASSERT_TRUE(std::regex_search(report, m, std::regex("\"frames_selected\": (\\d+)")));
  const int keyframes = std::stoi(m[1]);
  EXPECT_GT(keyframes, map_keyframes);
  // keyframes.tum: the header, then every keyframe of both halves.
  std::ifstream both(second / "keyframes.tum");
  std::string line;
  ASSERT_TRUE(std::getline(both, line));
  int lines = 0;
  while (std::getline(both, line)) ++lines;
  EXPECT_EQ(lines, keyframes);
  const double ate =
      EvaluateTrajectoryFiles((second / "groundtruth.tum").string(),
                              (second / "keyframes.tum").string(), EvaluationOptions())
          .ate.translation.rmse;
  EXPECT_LT(ate, 0.01);
  ASSERT_TRUE(fs::is_regular_file(second / "map" / "map.bin"));

  const testing_apps::CommandResult missing =
      testing_apps::RunIeslam("run --quiet --map " + (root_ / "no_map").string() + " --dataset " +
                              dataset + " --output " + (root_ / "no_map_out").string());
  EXPECT_EQ(missing.exit_code, 3) << missing.output;
  EXPECT_NE(missing.output.find((root_ / "no_map" / "map.bin").string()), std::string::npos)
      << missing.output;
  const testing_apps::CommandResult reckoning = testing_apps::RunIeslam(
      "run --quiet --selector deadreckoning --first 18 --map " + first.string() + " --dataset " +
      dataset + " --output " + (root_ / "reckoning").string());
  EXPECT_EQ(reckoning.exit_code, 2) << reckoning.output;
  EXPECT_NE(reckoning.output.find("needs a filter"), std::string::npos) << reckoning.output;
}

TEST_F(CommandRunTest, MissingDatasetIsADataErrorNamingIt) {
  const testing_apps::CommandResult missing =
      testing_apps::RunIeslam("run --dataset " + (root_ / "no_such_dataset").string() +
                              " --output " + (root_ / "missing").string());
  EXPECT_EQ(missing.exit_code, 3) << missing.output;
  EXPECT_NE(missing.output.find("no_such_dataset"), std::string::npos) << missing.output;
  EXPECT_FALSE(fs::exists(root_ / "missing"));
}

TEST_F(CommandRunTest, SigintMakesTheCommandExit130WithItsOutputs) {
  const std::string out = (root_ / "sigint").string();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const std::string dataset = (root_ / "synthetic").string();
    execl(IESLAM_BINARY, "ieslam", "run", "--dataset", dataset.c_str(), "--output", out.c_str(),
          "--threads", "1", "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until the run is under way: the handler is installed before the output directory
  // is made (a fixed sleep raced with process start-up on a loaded machine).
  for (int i = 0; i < 600 && !fs::exists(out); ++i) ::usleep(100 * 1000);
  ::usleep(300 * 1000);
  ::kill(child, SIGINT);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  const int code = WEXITSTATUS(status);
  if (code == 0) GTEST_SKIP() << "the run finished before the signal arrived";
  EXPECT_EQ(code, 130);
  EXPECT_NE(ReadFile(fs::path(out) / "report.json").find("\"interrupted\": true"),
            std::string::npos);
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  }
}

// Starts `ieslam run --dataset <synthetic> --output out --threads 1 --quiet <extra>`, sends
// `signal` once the run is under way and returns its exit code (-1: no normal exit).
int RunAndSignal(const fs::path& dataset, const fs::path& out, const char* extra, int signal) {
  const pid_t child = fork();
  if (child < 0) return -1;
  if (child == 0) {
    freopen("/dev/null", "w", stderr);
    execl(IESLAM_BINARY, "ieslam", "run", "--dataset", dataset.c_str(), "--output", out.c_str(),
          "--threads", "1", "--quiet", extra, static_cast<char*>(nullptr));
    _exit(127);
  }
  for (int i = 0; i < 600 && !fs::exists(out); ++i) ::usleep(100 * 1000);
  ::usleep(300 * 1000);
  ::kill(child, signal);
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// SIGTERM is handled as Ctrl-C, with its own exit code; the refinement it interrupts (or
// that would start after it) is no refinement: no refined.tum, the report says why.
TEST_F(CommandRunTest, SigtermStopsARefiningRunWith143AndNoRefinedTrajectory) {
  const fs::path out = root_ / "sigterm";
  const int code = RunAndSignal(root_ / "synthetic", out, "--refine", SIGTERM);
  if (code == 0) GTEST_SKIP() << "the run finished before the signal arrived";
  EXPECT_EQ(code, 143);
  const std::string report = ReadFile(out / "report.json");
  EXPECT_NE(report.find("\"interrupted\": true"), std::string::npos) << report;
  // Where the signal lands decides whether a refinement was done before it; refined.tum is
  // there only when one was.
  EXPECT_NE(fs::exists(out / "refined.tum"),
            report.find("\"refinement_failed\"") != std::string::npos);
  EXPECT_TRUE(fs::is_regular_file(out / "trajectory.tum"));
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  }
}

// The output directory is checked before the work: a path that cannot be a directory is bad
// usage (exit 2), found before any frame is read.
TEST_F(CommandRunTest, AnOutputDirectoryThatCannotBeMadeIsExit2BeforeTheWork) {
  const fs::path file = root_ / "a_file";
  std::ofstream(file) << "in the way\n";
  const testing_apps::CommandResult result = testing_apps::RunIeslam(
      "run --dataset " + (root_ / "synthetic").string() + " --output " + (file / "out").string());
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("cannot create output directory " + (file / "out").string()),
            std::string::npos)
      << result.output;
  EXPECT_EQ(result.output.find("frames selected"), std::string::npos) << result.output;
}

// `refine --output` the run's own directory keeps the run's files; a later run without
// --refine into it leaves no refinement of the earlier problem.
TEST_F(CommandRunTest, RefineIntoTheRunsDirectoryKeepsItsReportAndARerunClearsTheRefinement) {
  const fs::path out = root_ / "refine_in_place";
  const std::string run_command = "run --quiet --threads 1 --dataset " +
                                  (root_ / "synthetic").string() + " --output " + out.string();
  ASSERT_EQ(testing_apps::RunIeslam(run_command + " --refine").exit_code, 0);
  const std::string run_report = ReadFile(out / "report.json");
  const std::string run_refined = ReadFile(out / "refined.tum");
  const testing_apps::CommandResult refine =
      testing_apps::RunIeslam("refine --run " + out.string() + " --output " + out.string());
  ASSERT_EQ(refine.exit_code, 0) << refine.output;
  EXPECT_EQ(ReadFile(out / "report.json"), run_report);
  EXPECT_NE(ReadFile(out / "refine_report.json").find("\"filter_vs_smoother\""), std::string::npos);
  EXPECT_EQ(ReadFile(out / "refined.tum"), run_refined);
  EXPECT_TRUE(fs::is_regular_file(out / "refine_refined.tum"));
  ASSERT_EQ(testing_apps::RunIeslam(run_command).exit_code, 0);
  EXPECT_FALSE(fs::exists(out / "refined.tum"));
  EXPECT_FALSE(fs::exists(out / "refine_report.json"));
  EXPECT_FALSE(fs::exists(out / "refine_refined.tum"));
  EXPECT_TRUE(fs::is_regular_file(out / "report.json"));
}

// `ieslam refine --dataset` with the depth correction asked for prints it and writes the
// dataset's calibration with it (refine_corrected_calib.yaml into the run's directory, which a
// later run clears); a refine that reads that file as its calibration does not replace it.
TEST_F(CommandRunTest, RefineWritesTheCorrectedCalibrationButNotOverTheOneItReads) {
  const fs::path out = root_ / "depth_correction";
  const fs::path config = root_ / "estimate.yaml";
  std::ofstream(config) << "ba:\n  estimate_depth_correction: 1\n";
  const std::string dataset = " --dataset " + (root_ / "synthetic").string();
  const std::string run_command = "run --quiet --threads 1" + dataset + " --output " + out.string();
  ASSERT_EQ(testing_apps::RunIeslam(run_command).exit_code, 0);
  const std::string refine = "refine --threads 1 --run " + out.string() + dataset + " --config " +
                             config.string() + " --output ";
  const testing_apps::CommandResult into_run = testing_apps::RunIeslam(refine + out.string());
  ASSERT_EQ(into_run.exit_code, 0) << into_run.output;
  EXPECT_NE(into_run.output.find("refine: depth correction a "), std::string::npos)
      << into_run.output;
  ASSERT_TRUE(fs::is_regular_file(out / "refine_corrected_calib.yaml"));
  EXPECT_FALSE(fs::exists(out / "corrected_calib.yaml"));
  EXPECT_NE(ReadFile(out / "refine_corrected_calib.yaml").find("depth_correction"),
            std::string::npos);

  const fs::path other = root_ / "depth_correction_other";
  ASSERT_EQ(testing_apps::RunIeslam(refine + other.string()).exit_code, 0);
  const std::string written = ReadFile(other / "corrected_calib.yaml");
  const testing_apps::CommandResult again = testing_apps::RunIeslam(
      refine + other.string() + " --calib " + (other / "corrected_calib.yaml").string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("is the calibration the dataset was read with"), std::string::npos)
      << again.output;
  EXPECT_EQ(ReadFile(other / "corrected_calib.yaml"), written);

  // Applied, the refinement is made again with it, and both refined ATEs are printed and
  // reported.
  const fs::path apply = root_ / "apply.yaml";
  std::ofstream(apply) << "ba:\n  estimate_depth_correction: 1\n  apply_depth_correction: 1\n";
  const fs::path applied = root_ / "depth_correction_applied";
  const testing_apps::CommandResult one_pass =
      testing_apps::RunIeslam("refine --threads 1 --run " + out.string() + dataset + " --config " +
                              apply.string() + " --output " + applied.string());
  ASSERT_EQ(one_pass.exit_code, 0) << one_pass.output;
  EXPECT_NE(one_pass.output.find("refined keyframes without the depth correction"),
            std::string::npos)
      << one_pass.output;
  const std::string report = ReadFile(applied / "report.json");
  EXPECT_NE(report.find("\"refined_without_depth_correction\""), std::string::npos);
  EXPECT_NE(report.find("\"applied\": true"), std::string::npos);

  ASSERT_EQ(testing_apps::RunIeslam(run_command).exit_code, 0);
  EXPECT_FALSE(fs::exists(out / "refine_corrected_calib.yaml"));
}

}  // namespace
}  // namespace ieslam
