// `ieslam simulate`: the paper's simulation (§VI-A): Table I (all-frames EIF against the
// information-efficient selector with buffers 2-5) and the filter's consistency, averaged
// over Monte-Carlo runs that share the scene and draw fresh measurement noise.
#include <cstdio>
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/version.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/simulation_study.h"

namespace ieslam {
namespace {

const std::vector<FlagSpec> kSimulateFlags = {
    {"output", "OUT", "directory for table.md and report.json (required)"},
    {"runs", "N", "Monte-Carlo runs (default 1)"},
    {"seed", "S", "scene seed; run r draws its noise from seed S + r + 1 (default 1)"},
    {"buffers", "LIST", "look-ahead buffer sizes of the info rows (default 2,3,4,5)"},
    {"trajectory", "T", "polygon (the paper's) or rectangle (sharp 90 deg turns)"},
    {"config", "FILE", "options file (selector, filter and ba sections apply; --config of run)"},
    {"quiet", "", "no progress output"}};

SimulationStudyOptions StudyOptionsFromFlags(const Flags& flags) {
  SimulationStudyOptions options;
  options.runs = flags.GetInt("runs", 1, 1, 10000);
  options.seed = static_cast<uint32_t>(flags.GetInt("seed", 1, 0, 2000000000));
  options.buffers = flags.GetIntList("buffers", {2, 3, 4, 5}, 1, 100);
  const std::string trajectory = flags.GetString("trajectory", "polygon");
  if (trajectory == "rectangle") {
    options.simulation.trajectory.kind = SimulatedTrajectoryKind::kRectangle;
  } else if (trajectory != "polygon") {
    throw ConfigError("--trajectory must be polygon or rectangle, got '" + trajectory + "'");
  }
  RunOptions config;  // the selector, filter and ba sections of --config
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), &config);
  options.selector = config.pipeline.selector;
  options.filter = config.pipeline.filter;
  options.ba = config.pipeline.ba;
  return options;
}

Json StudyReport(const Flags& flags, const SimulationStudyOptions& options,
                 const SimulationStudy& study) {
  Json report = Json::Object()
                    .Set("version", IeslamVersion())
                    .Set("runs", study.runs_done)
                    .Set("interrupted", study.interrupted)
                    .Set("seed", static_cast<int64_t>(options.seed))
                    .Set("trajectory", ToString(options.simulation.trajectory.kind));
  report["options"].Set("buffers", Json::ArrayOf(options.buffers));
  report["options"].Set("config", flags.GetString("config", ""));
  report["options"].Set("runs", options.runs);  // asked for; "runs" above: those the table covers
  report["options"].Set("selector", SelectorOptions::Table().ToJson(options.selector));
  report["options"].Set("filter", InformationFilterOptions::Table().ToJson(options.filter));
  report["options"].Set("ba", BundleAdjustmentOptions::Table().ToJson(options.ba));
  report.Set("table", StudyRowsToJson(study.rows));
  report.Set("first_run_pose_errors", study.first_run_pose_errors);
  return report;
}

}  // namespace

int SimulateCommand(const CommandArgs& args) {
  const Flags flags(args, kSimulateFlags);
  if (flags.help()) {
    std::cout << FormatHelp("simulate", "--output OUT [flags]",
                            "The paper's simulation: 300 poses on a two-loop 3-D trajectory among\n"
                            "2000 random features; the all-frames EIF against the information-\n"
                            "efficient selector (Table I), with NEES consistency over the runs;\n"
                            "each row's estimate is also bundle-adjusted (BA ATE).",
                            kSimulateFlags);
    return 0;
  }
  const std::string output = flags.Require("output");
  const SimulationStudyOptions options = StudyOptionsFromFlags(flags);
  PrepareOutputDirectory(output);
  const int rows = static_cast<int>(options.Rows().size());
  Progress progress("simulate", options.runs * rows, flags.Has("quiet"));
  // Ctrl-C: the table covers the runs completed (or the rows of the first run done); held
  // until the files are written, so that a Ctrl-C then does not lose them.
  const StopOnInterrupt interrupt;
  const SimulationStudy study = RunSimulationStudy(
      options, [&progress](int done, int, const std::string& row) { progress.Update(done, row); },
      interrupt.Poll());
  progress.Finish();
  WriteTextAtomically(JoinPath(output, "report.json"),
                      StudyReport(flags, options, study).Dump() + "\n");
  const std::string markdown = StudyMarkdown(study, options);
  WriteTextAtomically(JoinPath(output, "table.md"), markdown);
  std::cout << markdown;
  if (study.interrupted) {
    std::fprintf(stderr,
                 "simulate: interrupted; the table has %zu of %d rows over %d of %d run(s)\n",
                 study.rows.size(), rows, study.runs_done, options.runs);
    return interrupt.exit_code();
  }
  return 0;
}

}  // namespace ieslam
