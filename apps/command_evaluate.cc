// `ieslam evaluate`: TUM-compatible ATE / RPE of an estimated trajectory.
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {

int EvaluateCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = {
      {"gt", "FILE", "ground truth, TUM format (required)"},
      {"est", "FILE", "estimate, TUM format (required)"},
      {"max-diff", "S", "association window in seconds (default 0.02)"},
      {"offset", "S", "added to the estimate's timestamps (default 0)"},
      {"scale", "X", "multiplies the estimate's translations (default 1)"},
      {"delta", "D", "RPE step (default 1)"},
      {"delta-unit", "U", "s (seconds) or f (frames) (default s)"},
      {"output", "OUT", "also write OUT/evaluation.json"}};
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("evaluate", "--gt FILE --est FILE [flags]",
                            "Absolute trajectory error (Horn alignment, no scale) and fixed-delta\n"
                            "relative pose error, with the TUM RGB-D benchmark's conventions.",
                            specs);
    return 0;
  }
  EvaluationOptions options;
  options.max_diff_s = flags.GetDouble("max-diff", options.max_diff_s, 0.0, 1e6);
  options.offset_s = flags.GetDouble("offset", options.offset_s, -1e12, 1e12);
  options.scale = flags.GetDouble("scale", options.scale, 1e-9, 1e9);
  options.delta = flags.GetDouble("delta", options.delta, 0.0, 1e12);
  const std::string unit = flags.GetString("delta-unit", "s");
  if (!ParseDeltaUnit(unit, &options.delta_unit)) {
    throw ConfigError("--delta-unit must be s or f, got '" + unit + "'");
  }
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);

  // The trajectories are read before OUT is made (bad input leaves no directory behind), and
  // OUT before anything is printed (an unwritable OUT is an error, not a half success).
  const std::string output = flags.GetString("output", "");
  const EvaluationResult result =
      EvaluateTrajectoryFiles(flags.Require("gt"), flags.Require("est"), options);
  if (!output.empty()) PrepareOutputDirectory(output);
  for (const std::string& warning : result.warnings) std::cerr << "warning: " << warning << "\n";
  std::cout << FormatEvaluation(result);
  if (!output.empty()) {
    WriteTextAtomically(JoinPath(output, "evaluation.json"), EvaluationToJson(result));
  }
  return 0;
}

}  // namespace ieslam
