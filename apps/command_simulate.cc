// `ieslam simulate`: the paper's simulation (§VI-A): Table I (all-frames EIF against the
// information-efficient selector with buffers 2-5) and the filter's consistency, averaged
// over Monte-Carlo runs that share the scene and draw fresh measurement noise.
#include <cstdio>
#include <iostream>
#include <sstream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/version.h"
#include "selection/pipeline/run_options.h"
#include "selection/pipeline/simulation_shards.h"
#include "selection/pipeline/simulation_study.h"

namespace ieslam {
namespace {

const std::vector<FlagSpec> kSimulateFlags = {
    {"output", "OUT", "directory for table.md, report.json, runs.tsv and config.yaml (required)"},
    {"runs", "N", "Monte-Carlo runs (default 1)"},
    {"first-run", "K",
     "a shard: runs K .. K+N-1 with the seeds one process gives them (default 0)"},
    {"poses", "N", "poses of the trajectory over its two loops (default 300, the paper's)"},
    {"merge", "DIRS", "comma-separated shard outputs: merge their runs.tsv into one table"},
    {"seed", "S", "scene seed; run r draws its noise from seed S + r + 1 (default 1)"},
    {"buffers", "LIST", "look-ahead buffer sizes of the info rows (default 2,3,4,5)"},
    {"trajectory", "T", "polygon (the paper's) or rectangle (sharp 90 deg turns)"},
    {"config", "FILE",
     "options file (selector, filter and ba sections apply; --config of run; the observation "
     "gate, filter.gate_chi2, is off unless it sets it)"},
    {"quiet", "", "no progress output"}};

SimulationStudyOptions StudyOptionsFromFlags(const Flags& flags, RunOptions* config) {
  SimulationStudyOptions options;
  options.runs = flags.GetInt("runs", 1, 1, 10000);
  options.first_run = flags.GetInt("first-run", 0, 0, 1000000);
  options.simulation.trajectory.num_poses = flags.GetInt("poses", 300, 10, 100000);
  options.seed = static_cast<uint32_t>(flags.GetInt("seed", 1, 0, 2000000000));
  options.buffers = flags.GetIntList("buffers", {2, 3, 4, 5}, 1, 100);
  const std::string trajectory = flags.GetString("trajectory", "polygon");
  if (trajectory == "rectangle") {
    options.simulation.trajectory.kind = SimulatedTrajectoryKind::kRectangle;
  } else if (trajectory != "polygon") {
    throw ConfigError("--trajectory must be polygon or rectangle, got '" + trajectory + "'");
  }
  // The selector, filter and ba sections of --config.
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), config);
  options.selector = config->pipeline.selector;
  options.filter = config->pipeline.filter;
  options.ba = config->pipeline.ba;
  return options;
}

Json StudyReport(const std::string& config_path, const SimulationStudyOptions& options,
                 const SimulationStudy& study) {
  Json report = Json::Object()
                    .Set("version", IeslamVersion())
                    .Set("runs", study.runs_done)
                    .Set("interrupted", study.interrupted)
                    .Set("seed", static_cast<int64_t>(options.seed))
                    .Set("trajectory", ToString(options.simulation.trajectory.kind));
  report["options"].Set("buffers", Json::ArrayOf(options.buffers));
  report["options"].Set("config", config_path);
  report["options"].Set("runs", options.runs);  // asked for; "runs" above: those the table covers
  report["options"].Set("first_run", study.first_run);
  report["options"].Set("poses", options.simulation.trajectory.num_poses);
  report["options"].Set("selector", SelectorOptions::Table().ToJson(options.selector));
  report["options"].Set("filter", InformationFilterOptions::Table().ToJson(options.filter));
  report["options"].Set("ba", BundleAdjustmentOptions::Table().ToJson(options.ba));
  report.Set("table", StudyRowsToJson(study.rows));
  report.Set("first_run_pose_errors", study.first_run_pose_errors);
  return report;
}

// Every output of a study: report.json, table.md (also printed), runs.tsv and config.yaml
// (the options a shard ran with, read back by a merge).
void WriteStudy(const std::string& output, const std::string& config_path,
                const SimulationStudyOptions& options, const RunOptions& config,
                const SimulationStudy& study) {
  WriteTextAtomically(JoinPath(output, "report.json"),
                      StudyReport(config_path, options, study).Dump() + "\n");
  WriteTextAtomically(JoinPath(output, "runs.tsv"), StudyRunsTsv(study, options));
  WriteTextAtomically(JoinPath(output, "config.yaml"), ConfigYaml(config));
  const std::string markdown = StudyMarkdown(study, options);
  WriteTextAtomically(JoinPath(output, "table.md"), markdown);
  std::cout << markdown;
}

// --merge: the shards' runs.tsv as one study, with the options of the first shard's
// config.yaml (every shard's runs.tsv must name the same).
int MergeShards(const Flags& flags, const std::string& output) {
  std::vector<StudyShard> shards;
  std::istringstream list(flags.Require("merge"));
  std::string dir;
  while (std::getline(list, dir, ',')) {
    if (!dir.empty()) shards.push_back(ReadStudyRunsTsv(JoinPath(dir, "runs.tsv")));
  }
  const StudyShard merged = MergeStudyShards(std::move(shards));
  const std::string config_path = JoinPath(
      merged.path.substr(0, merged.path.size() - std::string("runs.tsv").size()), "config.yaml");
  RunOptions config = StudyRunOptions();
  try {
    ApplyConfigFile(config_path, &config);
  } catch (const ConfigError& e) {  // a shard's file, not the user's options
    throw DataError(e.what());
  }
  SimulationStudyOptions options;
  options.seed = merged.seed;
  options.runs = merged.study.runs_done;
  options.first_run = merged.study.first_run;
  options.buffers = merged.buffers;
  options.simulation.trajectory.num_poses = merged.poses;
  if (merged.trajectory == "rectangle") {
    options.simulation.trajectory.kind = SimulatedTrajectoryKind::kRectangle;
  } else if (merged.trajectory != "polygon") {
    throw DataError(merged.path + ": unknown trajectory '" + merged.trajectory + "'");
  }
  options.selector = config.pipeline.selector;
  options.filter = config.pipeline.filter;
  options.ba = config.pipeline.ba;
  if (StudyOptionsJson(options).Dump(0) != merged.options_json) {
    throw DataError(config_path + ": its selector, filter or ba options differ from those in " +
                    merged.path);
  }
  PrepareOutputDirectory(output);
  WriteStudy(output, config_path, options, config, merged.study);
  return 0;
}

}  // namespace

int SimulateCommand(const CommandArgs& args) {
  const Flags flags(args, kSimulateFlags);
  if (flags.help()) {
    std::cout << FormatHelp("simulate", "--output OUT [flags]",
                            "The paper's simulation: 300 poses on a two-loop 3-D trajectory among\n"
                            "2000 random features; the all-frames EIF against the information-\n"
                            "efficient selector (Table I), with NEES consistency over the runs;\n"
                            "each row's estimate is also bundle-adjusted (BA ATE).\n"
                            "Shards: `--first-run K --runs N` runs runs K..K+N-1 with the seeds\n"
                            "one process gives them; `--merge OUT1,OUT2,... --output OUT` merges\n"
                            "the shards' runs.tsv into the table one process would print.",
                            kSimulateFlags);
    return 0;
  }
  const std::string output = flags.Require("output");
  if (flags.Has("merge")) return MergeShards(flags, output);
  RunOptions config = StudyRunOptions();
  const SimulationStudyOptions options = StudyOptionsFromFlags(flags, &config);
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
  WriteStudy(output, flags.GetString("config", ""), options, config, study);
  if (study.interrupted) {
    std::fprintf(stderr,
                 "simulate: interrupted; the table has %zu of %d rows over %d of %d run(s)\n",
                 study.rows.size(), rows, study.runs_done, options.runs);
    return interrupt.exit_code();
  }
  return 0;
}

}  // namespace ieslam
