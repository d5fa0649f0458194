// `ieslam options`: every option of `ieslam run` with its default and help, as a config file.
#include <iostream>

#include "apps/commands.h"
#include "apps/flags.h"
#include "selection/pipeline/run_options.h"

namespace ieslam {

int OptionsCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = {
      {"config", "FILE", "print the options of this config file (checked) instead"}};
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("options", "[--config FILE]",
                            "Prints every option of every stage with its default and its help,\n"
                            "as a file `ieslam run --config` reads (data/config/default.yaml).",
                            specs);
    return 0;
  }
  RunOptions options;
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), &options);
  std::cout << ConfigYaml(options);
  return 0;
}

}  // namespace ieslam
