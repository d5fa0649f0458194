// `ieslam evaluate`: TUM-compatible ATE / RPE of an estimated trajectory.
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/option_flags.h"
#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {

const OptionRegistry<EvaluationOptions>& EvaluationRegistry() {
  static const OptionRegistry<EvaluationOptions>* registry = [] {
    auto* r = new OptionRegistry<EvaluationOptions>;
    r->Section<EvaluationOptions>("", EvaluationOptions::Table(),
                                  [](EvaluationOptions* o) { return o; });
    return r;
  }();
  return *registry;
}

const std::vector<OptionFlag>& EvaluateOptionFlags() {
  static const std::vector<OptionFlag>* flags =
      new std::vector<OptionFlag>{{"max-diff", "max_diff_s"},
                                  {"offset", "offset_s"},
                                  {"scale", "scale"},
                                  {"delta", "delta"},
                                  {"delta-unit", "delta_unit"}};
  return *flags;
}

int EvaluateCommand(const CommandArgs& args) {
  std::vector<FlagSpec> specs = {{"gt", "FILE", "ground truth, TUM format (required)"},
                                 {"est", "FILE", "estimate, TUM format (required)"},
                                 {"output", "OUT", "also write OUT/evaluation.json"}};
  const std::vector<FlagSpec> option_specs =
      OptionFlagSpecs(EvaluationRegistry(), EvaluateOptionFlags());
  specs.insert(specs.end(), option_specs.begin(), option_specs.end());
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("evaluate", "--gt FILE --est FILE [flags]",
                            "Absolute trajectory error (Horn alignment, no scale) and fixed-delta\n"
                            "relative pose error, with the TUM RGB-D benchmark's conventions.",
                            specs);
    return 0;
  }
  EvaluationOptions options;
  ApplyOptionFlags(flags, EvaluationRegistry(), EvaluateOptionFlags(), &options);
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);

  // The trajectories are read before OUT is made (bad input leaves no directory behind), and
  // OUT before anything is printed (an unwritable OUT is an error, not a half success).
  const std::string output = flags.GetString("output", "");
  const EvaluationResult result =
      EvaluateTrajectoryFiles(flags.Require("gt"), flags.Require("est"), options);
  if (!output.empty()) PrepareOutputDirectory(output);
  for (const std::string& warning : result.warnings) std::cerr << "warning: " << warning << "\n";
  if (!result.ate_unavailable.empty()) {
    std::cerr << "warning: no ATE: " << result.ate_unavailable << "\n";
  }
  if (!result.rpe_unavailable.empty()) {
    std::cerr << "warning: no RPE: " << result.rpe_unavailable << "\n";
  }
  std::cout << FormatEvaluation(result);
  if (!output.empty()) {
    WriteTextAtomically(JoinPath(output, "evaluation.json"), EvaluationToJson(result));
  }
  return 0;
}

}  // namespace ieslam
