// The `ieslam` binary as users and outside checks see it: subcommands, help, exit codes.
#include <string>

#include <gtest/gtest.h>

#include "command_test_util.h"

namespace {

using ieslam::testing_apps::CommandResult;
using ieslam::testing_apps::RunIeslam;
using Result = CommandResult;

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

TEST(CliTest, VersionPrintsTheProjectVersion) {
  const Result result = RunIeslam("--version");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_EQ(result.output.rfind("ieslam ", 0), 0u) << result.output;
}

}  // namespace
