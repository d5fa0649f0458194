// The `ieslam` binary as users and outside checks see it: subcommands, help, exit codes.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "command_test_util.h"

namespace {

using ieslam::testing_apps::CommandResult;
using ieslam::testing_apps::ReadFile;
using ieslam::testing_apps::RunIeslam;
using Result = CommandResult;
namespace fs = std::filesystem;

// Starts `ieslam args...` (output to /dev/null), waits until `started` exists (the command
// makes its output directory before the work), lets it work `work_ms`, sends SIGINT and
// returns the exit code (-1 when it did not exit normally).
int ExitCodeAfterSigint(const std::vector<std::string>& args, const fs::path& started,
                        int work_ms) {
  const pid_t child = fork();
  if (child < 0) return -1;
  if (child == 0) {
    std::vector<char*> argv{const_cast<char*>("ieslam")};
    for (const std::string& arg : args) argv.push_back(const_cast<char*>(arg.c_str()));
    argv.push_back(nullptr);
    freopen("/dev/null", "w", stdout);
    freopen("/dev/null", "w", stderr);
    execv(IESLAM_BINARY, argv.data());
    _exit(127);
  }
  for (int i = 0; i < 600 && !fs::exists(started); ++i) ::usleep(100 * 1000);
  ::usleep(work_ms * 1000);
  ::kill(child, SIGINT);
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

fs::path TempPath(const std::string& name) {
  const fs::path path =
      fs::temp_directory_path() / ("ieslam_cli_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(path);
  return path;
}

TEST(CliTest, HelpListsEverySubcommandOfTheInterface) {
  const Result result = RunIeslam("--help");
  EXPECT_EQ(result.exit_code, 0);
  for (const char* command : {"run", "evaluate", "simulate", "synth", "register", "refine"}) {
    EXPECT_NE(result.output.find(std::string("  ") + command + " "), std::string::npos) << command;
  }
}

TEST(CliTest, NoArgumentsOrAnUnknownCommandIsAUsageError) {
  EXPECT_EQ(RunIeslam("").exit_code, 2);
  const Result result = RunIeslam("frobnicate");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.output.find("frobnicate"), std::string::npos);
}

TEST(CliTest, QuietAndVerboseTogetherAreAUsageErrorNamingBoth) {
  const Result result = RunIeslam("run --dataset /nonexistent --output /tmp/x --quiet --verbose");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.output.find("--quiet and --verbose"), std::string::npos) << result.output;
}

// Ctrl-C is exit 130 for every command, and what was processed is written (run's own
// test: command_run_test).
TEST(CliTest, SigintEndsSimulateWith130AndTheRowsDone) {
  const fs::path out = TempPath("simulate");
  const int code = ExitCodeAfterSigint(
      {"simulate", "--output", out.string(), "--runs", "50", "--buffers", "3", "--quiet"}, out, 30);
  ASSERT_EQ(code, 130);
  // Stopped within the first run (its first row takes seconds): a report of what was done,
  // which may be nothing, not a crash.
  const std::string report = ReadFile(out / "report.json");
  EXPECT_NE(report.find("\"interrupted\": true"), std::string::npos) << report;
  EXPECT_TRUE(report.find("\"runs\": 0,") != std::string::npos ||
              report.find("\"runs\": 1,") != std::string::npos)
      << report;
  EXPECT_NE(ReadFile(out / "table.md").find("Table I"), std::string::npos);
  fs::remove_all(out);
}

TEST(CliTest, SigintEndsSynthWith130AndAShorterCompleteDataset) {
  const fs::path out = TempPath("synth");
  const int code =
      ExitCodeAfterSigint({"synth", "--output", out.string(), "--frames", "5000"}, out, 500);
  ASSERT_EQ(code, 130);
  const std::string list = ReadFile(out / "rgb.txt");
  int frames = 0;
  for (size_t at = list.find('\n'); at != std::string::npos; at = list.find('\n', at + 1)) {
    ++frames;
  }
  frames -= 3;  // the TUM header
  EXPECT_GE(frames, 0);
  EXPECT_LT(frames, 5000);
  EXPECT_NE(ReadFile(out / "synthetic.txt").find("frames: " + std::to_string(frames) + "\n"),
            std::string::npos);
  fs::remove_all(out);
}

// The binary moved out of the build tree, laid out as `cmake --install` lays it out, reads the
// calibration installed beside it, or the one IESLAM_DATA_DIR names.
TEST(CliTest, AnInstalledBinaryFindsItsDataBesideItselfOrInIeslamDataDir) {
  const fs::path prefix = TempPath("installed");
  fs::create_directories(prefix / "bin");
  fs::create_directories(prefix / "share/ieslam");
  fs::create_directories(prefix / "elsewhere");
  fs::copy_file(IESLAM_BINARY, prefix / "bin/ieslam");
  const fs::path source_calib = fs::path(IESLAM_SOURCE_DIR) / "data/calib";
  fs::copy(source_calib, prefix / "share/ieslam/calib");
  fs::copy(source_calib, prefix / "elsewhere/calib");
  // A TUM sequence whose name names no camera: the warning names the calibration file used.
  const fs::path sequence = prefix / "sequence";
  fs::create_directories(sequence);
  const fs::path tum = fs::path(IESLAM_SHARED_DATA_DIR) / "tum-fr1-desk-9";
  for (const char* name : {"rgb", "depth", "rgb.txt", "depth.txt", "groundtruth.txt"}) {
    fs::create_symlink(tum / name, sequence / name);
  }
  const std::string command = "register --quiet --step 1 --last 1 --dataset " + sequence.string() +
                              " --output " + (prefix / "out").string() + " 2>&1";
  auto run = [&](const std::string& environment) {
    CommandResult result;
    FILE* pipe =
        popen((environment + " " + (prefix / "bin/ieslam").string() + " " + command).c_str(), "r");
    char buffer[4096];
    size_t n;
    while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.output.append(buffer, n);
    const int status = pclose(pipe);
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return result;
  };
  const Result installed = run("env -u IESLAM_DATA_DIR");
  EXPECT_EQ(installed.exit_code, 0) << installed.output;
  EXPECT_NE(installed.output.find((prefix / "share/ieslam/calib/tum_fr1.yaml").string()),
            std::string::npos)
      << installed.output;
  const Result named = run("IESLAM_DATA_DIR=" + (prefix / "elsewhere").string());
  EXPECT_EQ(named.exit_code, 0) << named.output;
  EXPECT_NE(named.output.find((prefix / "elsewhere/calib/tum_fr1.yaml").string()),
            std::string::npos)
      << named.output;
  fs::remove_all(prefix);
}

// --dense adds the depth's own alignment of each pair, under its own keys, to the features'.
TEST(CliTest, RegisterDenseAddsTheDepthAlignmentOfEachPair) {
  const fs::path out =
      fs::temp_directory_path() / ("ieslam_cli_register_dense_" + std::to_string(::getpid()));
  const std::string dataset = (fs::path(IESLAM_SHARED_DATA_DIR) / "tum-fr1-desk-9").string();
  const Result result = RunIeslam("register --quiet --step 1 --last 2 --dense --dataset " +
                                  dataset + " --output " + out.string());
  EXPECT_EQ(result.exit_code, 0) << result.output;
  for (const char* key :
       {"register.pairs 2", "register.trans_err_rms_z_m ", "register.dense.pairs 2",
        "register.dense.success_rate ", "register.dense.trans_err_rms_z_m "}) {
    EXPECT_NE(result.output.find(key), std::string::npos) << key << "\n" << result.output;
  }
  const std::string json = ieslam::testing_apps::ReadFile((out / "register.json").string());
  EXPECT_NE(json.find("\"dense\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"trans_err_xyz_m\""), std::string::npos) << json;
  fs::remove_all(out);
}

TEST(CliTest, VersionPrintsTheProjectVersion) {
  const Result result = RunIeslam("--version");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_EQ(result.output.rfind("ieslam ", 0), 0u) << result.output;
}

}  // namespace
