// The subcommands of `ieslam`. Each takes the arguments after its name and returns the
// process exit code; ConfigError and DataError propagate to main, which maps them to
// exit codes 2 and 3.
#pragma once

#include <string>
#include <vector>

namespace ieslam {

using CommandArgs = std::vector<std::string>;

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const CommandArgs& args);
};

// Every subcommand, in the order `ieslam --help` lists them.
const std::vector<Command>& Commands();

int EvaluateCommand(const CommandArgs& args);
int LocalizeCommand(const CommandArgs& args);
int OptionsCommand(const CommandArgs& args);
int RefineCommand(const CommandArgs& args);
int RegisterCommand(const CommandArgs& args);
int RunCommand(const CommandArgs& args);
int SimulateCommand(const CommandArgs& args);
int SynthCommand(const CommandArgs& args);

}  // namespace ieslam
