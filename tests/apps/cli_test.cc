// The `ieslam` binary as users and outside checks see it: subcommands, help, exit codes.
#include <array>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace {

struct Result {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

Result RunIeslam(const std::string& args) {
  const std::string command = std::string(IESLAM_BINARY) + " " + args + " 2>&1";
  Result result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
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

TEST(CliTest, VersionPrintsTheProjectVersion) {
  const Result result = RunIeslam("--version");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_EQ(result.output.rfind("ieslam ", 0), 0u) << result.output;
}

}  // namespace
