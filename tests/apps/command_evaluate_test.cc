// `ieslam evaluate` end to end: what it prints and exits with for trajectories too short for
// part of the evaluation.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "command_test_util.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;
using testing_apps::ReadFile;
using testing_apps::RunIeslam;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class CommandEvaluateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("ieslam_command_evaluate_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  // `n` poses at 30 Hz moving along x, in TUM format.
  std::string WriteTrajectory(const std::string& name, int n) const {
    const fs::path path = root_ / name;
    std::ofstream out(path);
    for (int i = 0; i < n; ++i) {
      out << 100.0 + i / 30.0 << " " << 0.01 * i << " 0 " << 0.001 * i * i << " 0 0 0 1\n";
    }
    return path.string();
  }
  fs::path root_;
};

// A 9-frame run's files: the ATE is there, the RPE at the default 1 s delta has no pair.
TEST_F(CommandEvaluateTest, AShortTrajectoryGetsItsAteAndAReasonForTheMissingRpe) {
  const std::string gt = WriteTrajectory("gt.txt", 9);
  const std::string est = WriteTrajectory("est.txt", 9);
  const fs::path out = root_ / "out";
  const auto r = RunIeslam("evaluate --gt " + gt + " --est " + est + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Contains(r.output, "ate.pairs 9\n")) << r.output;
  EXPECT_TRUE(Contains(r.output, "ate.rmse 0.000000\n")) << r.output;
  EXPECT_TRUE(Contains(r.output, "rpe.pairs 0\n")) << r.output;
  EXPECT_FALSE(Contains(r.output, "rpe.trans.rmse")) << r.output;
  EXPECT_TRUE(Contains(r.output, "warning: no RPE: only 0 relative-pose pairs (delta 1 s)"))
      << r.output;
  const std::string json = ReadFile(out / "evaluation.json");
  EXPECT_TRUE(Contains(json, "\"trans\": null")) << json;
  EXPECT_TRUE(Contains(json, "\"unavailable\"")) << json;

  // A delta the trajectory spans gives the RPE too.
  const auto frames =
      RunIeslam("evaluate --gt " + gt + " --est " + est + " --delta 1 --delta-unit f");
  ASSERT_EQ(frames.exit_code, 0) << frames.output;
  EXPECT_TRUE(Contains(frames.output, "rpe.pairs 7\n")) << frames.output;
  EXPECT_FALSE(Contains(frames.output, "warning")) << frames.output;
}

TEST_F(CommandEvaluateTest, NothingComputableIsExit3WithBothReasons) {
  const std::string gt = WriteTrajectory("gt.txt", 9);
  const std::string est = WriteTrajectory("est.txt", 2);
  const auto r = RunIeslam("evaluate --gt " + gt + " --est " + est);
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, "no ATE: only 2 poses of " + est)) << r.output;
  EXPECT_TRUE(Contains(r.output, "no RPE: ")) << r.output;
}

}  // namespace
}  // namespace ieslam
