// `ieslam simulate` sharded end to end: shards merged against one process with the same
// seeds, and the merge's exit code and message for shards that do not fit together.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "command_test_util.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;
using testing_apps::ReadFile;
using testing_apps::RunIeslam;

// runs.tsv without its wall-time columns (seconds, seconds_selection, seconds_filter,
// seconds_ba: fields 7-9 and 15), which are measured, not drawn from the seeds.
std::string WithoutTimes(const std::string& tsv) {
  std::istringstream in(tsv);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.rfind("# first_run", 0) == 0 || line.rfind("# runs", 0) == 0) continue;
    std::istringstream fields(line);
    std::string field;
    for (int i = 1; std::getline(fields, field, '\t'); ++i) {
      if (line[0] == '#' || (i < 7 || (i > 9 && i < 15))) out += field + "\t";
    }
    out += "\n";
  }
  return out;
}

class CommandSimulateTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new fs::path(fs::temp_directory_path() /
                         ("ieslam_command_simulate_test_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    fs::create_directories(*root_);
    const std::string common = " --poses 40 --buffers 3 --quiet --output ";
    for (const auto& [name, runs] : std::vector<std::pair<std::string, std::string>>{
             {"one", "--runs 3"},
             {"a", "--runs 2"},
             {"b", "--first-run 2 --runs 1"},
             {"seed", "--first-run 2 --runs 1 --seed 6"}}) {
      const std::string args = "simulate " + runs + common + Dir(name);
      ASSERT_EQ(RunIeslam(args).exit_code, 0) << args;
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete root_;
  }
  static std::string Dir(const std::string& name) { return (*root_ / name).string(); }
  static fs::path* root_;
};
fs::path* CommandSimulateTest::root_ = nullptr;

TEST_F(CommandSimulateTest, TwoShardsMergeToTheRunsOfOneProcess) {
  const auto merged =
      RunIeslam("simulate --merge " + Dir("b") + "," + Dir("a") + " --output " + Dir("merged"));
  ASSERT_EQ(merged.exit_code, 0) << merged.output;
  const std::string one = ReadFile(*root_ / "one" / "runs.tsv");
  ASSERT_FALSE(one.empty());
  EXPECT_EQ(WithoutTimes(ReadFile(*root_ / "merged" / "runs.tsv")), WithoutTimes(one));
  EXPECT_NE(ReadFile(*root_ / "merged" / "table.md").find("3 Monte-Carlo run(s)"),
            std::string::npos);
  EXPECT_NE(ReadFile(*root_ / "merged" / "report.json").find("\"runs\": 3"), std::string::npos);
}

// The same per-run values (here one process's own) give the same table, every byte of it.
TEST_F(CommandSimulateTest, AMergeRecomputesTheTableToEveryDigit) {
  const auto merged = RunIeslam("simulate --merge " + Dir("one") + " --output " + Dir("again"));
  ASSERT_EQ(merged.exit_code, 0) << merged.output;
  EXPECT_EQ(ReadFile(*root_ / "again" / "table.md"), ReadFile(*root_ / "one" / "table.md"));
  EXPECT_EQ(ReadFile(*root_ / "again" / "runs.tsv"), ReadFile(*root_ / "one" / "runs.tsv"));
  const std::string one = ReadFile(*root_ / "one" / "report.json");
  const std::string again = ReadFile(*root_ / "again" / "report.json");
  const auto table = [](const std::string& report) {
    const size_t begin = report.find("\"table\"");
    return report.substr(begin, report.find("\"first_run_pose_errors\"") - begin);
  };
  EXPECT_EQ(table(again), table(one));
}

// The paper's experiment runs without the observation gate (run's default has it on) unless
// the config turns it on.
TEST_F(CommandSimulateTest, TheObservationGateIsOffUnlessTheConfigSetsIt) {
  const std::string config = ReadFile(*root_ / "one" / "config.yaml");
  EXPECT_NE(config.find("gate_chi2: 0.0"), std::string::npos) << config;
  const fs::path gated = *root_ / "gated.yaml";
  std::ofstream(gated) << "filter:\n  gate_chi2: 16.27\n";
  const auto run = RunIeslam("simulate --poses 40 --buffers 3 --runs 1 --quiet --config " +
                             gated.string() + " --output " + Dir("gated"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(ReadFile(*root_ / "gated" / "config.yaml").find("gate_chi2: 16.27"), std::string::npos);
}

TEST_F(CommandSimulateTest, ShardsThatDoNotFitExitWith3NamingTheFile) {
  const auto overlap =
      RunIeslam("simulate --merge " + Dir("a") + "," + Dir("one") + " --output " + Dir("bad"));
  EXPECT_EQ(overlap.exit_code, 3);
  EXPECT_NE(overlap.output.find(Dir("one") + "/runs.tsv: runs 0 to 2 overlap"), std::string::npos)
      << overlap.output;
  const auto seed =
      RunIeslam("simulate --merge " + Dir("a") + "," + Dir("seed") + " --output " + Dir("bad"));
  EXPECT_EQ(seed.exit_code, 3);
  EXPECT_NE(seed.output.find(Dir("seed") + "/runs.tsv: seed 6 differs"), std::string::npos)
      << seed.output;
  fs::create_directories(*root_ / "cut");
  fs::copy_file(*root_ / "b" / "config.yaml", *root_ / "cut" / "config.yaml");
  const std::string b = ReadFile(*root_ / "b" / "runs.tsv");
  std::ofstream(*root_ / "cut" / "runs.tsv") << b.substr(0, b.size() - 30);
  const auto cut =
      RunIeslam("simulate --merge " + Dir("a") + "," + Dir("cut") + " --output " + Dir("bad"));
  EXPECT_EQ(cut.exit_code, 3);
  EXPECT_NE(cut.output.find(Dir("cut") + "/runs.tsv:"), std::string::npos) << cut.output;
}

}  // namespace
}  // namespace ieslam
