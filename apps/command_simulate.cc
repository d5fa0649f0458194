// `ieslam simulate`: the paper's simulation (§VI-A): Table I (all-frames EIF against the
// information-efficient selector with buffers 2-5) and the filter's consistency, averaged
// over Monte-Carlo runs that share the scene and draw fresh measurement noise.
#include <cstdio>
#include <iostream>
#include <sstream>

#include "apps/app_util.h"
#include "apps/batch_refinement.h"
#include "apps/commands.h"
#include "apps/config_file.h"
#include "apps/interrupt.h"
#include "apps/run_pipeline.h"
#include "backend/evaluation/consistency.h"
#include "core/error.h"
#include "core/file_util.h"
#include "frontend/simulation/paper_simulation.h"
#include "selection/pipeline/known_association_run.h"

namespace ieslam {
namespace {

struct TableRow {
  std::string selector;
  int buffer = 0;
  double frames_total = 0, frames_used = 0, state_dim = 0, seconds = 0, final_pose_error_m = 0,
         ate_rmse_m = 0, mean_nees = 0, within_2sigma = 0, refined_ate_rmse_m = 0,
         refined_not_worse = 0, seconds_ba = 0, seconds_selection = 0, seconds_filter = 0;
  std::pair<double, double> nees_band;
};

void Accumulate(const KnownAssociationMetrics& m, double weight, TableRow* row) {
  row->frames_total += weight * m.frames_total;
  row->frames_used += weight * m.frames_used;
  row->state_dim += weight * m.state_dim;
  row->seconds += weight * m.seconds;
  row->seconds_selection += weight * m.seconds_selection;
  row->seconds_filter += weight * m.seconds_filter;
  row->final_pose_error_m += weight * m.final_pose_error_m;
  row->ate_rmse_m += weight * m.ate_rmse_m;
  row->mean_nees += weight * m.mean_nees;
  row->within_2sigma += weight * m.within_2sigma;
  row->refined_ate_rmse_m += weight * m.refined_ate_rmse_m;
  row->refined_not_worse += weight * (m.refined_ate_rmse_m <= m.ate_rmse_m ? 1.0 : 0.0);
  row->seconds_ba += weight * m.seconds_ba;
}

Json RowToJson(const TableRow& row) {
  return Json::Object()
      .Set("selector", row.selector)
      .Set("buffer", row.buffer)
      .Set("frames_total", row.frames_total)
      .Set("frames_used", row.frames_used)
      .Set("state_dim", row.state_dim)
      .Set("seconds", row.seconds)
      .Set("seconds_selection", row.seconds_selection)
      .Set("seconds_filter", row.seconds_filter)
      .Set("final_pose_error_m", row.final_pose_error_m)
      .Set("ate_rmse_m", row.ate_rmse_m)
      .Set("mean_nees", row.mean_nees)
      .Set("nees_band",
           Json::ArrayOf(std::vector<double>{row.nees_band.first, row.nees_band.second}))
      .Set("within_2sigma", row.within_2sigma)
      .Set("refined_ate_rmse_m", row.refined_ate_rmse_m)
      .Set("refined_not_worse", row.refined_not_worse)
      .Set("seconds_ba", row.seconds_ba);
}

// The table's buffer column: the info rows' look-ahead buffer, 0 for the all-frames row.
int BufferOfRow(const SelectorOptions& row) {
  return row.kind == SelectorKind::kInfo ? row.buffer_size : 0;
}

// One row's per-pose errors, sigmas and NEES (report.json: first_run_pose_errors).
Json PoseErrorsToJson(const SelectorOptions& row, const KnownAssociationMetrics& metrics) {
  Json errors = Json::Array();
  for (const PoseErrorRecord& e : metrics.pose_errors) {
    errors.Push(
        Json::Object()
            .Set("frame", e.frame)
            .Set("error", Json::ArrayOf(std::vector<double>(e.error.data(), e.error.data() + 6)))
            .Set("sigma", Json::ArrayOf(std::vector<double>(e.sigma.data(), e.sigma.data() + 6)))
            .Set("nees", e.nees));
  }
  return Json::Object()
      .Set("selector", SelectorKindName(row.kind))
      .Set("buffer", BufferOfRow(row))
      .Set("poses", errors);
}

std::string TableMarkdown(const std::vector<TableRow>& rows, int runs, uint32_t seed,
                          const std::string& trajectory) {
  std::ostringstream s;
  s << "# ieslam simulate: the paper's Table I\n\n"
    << "Trajectory `" << trajectory << "`, " << runs << " Monte-Carlo run(s), seed " << seed
    << "; means over the runs. Paper (§VI-A, buffer 3): 163 of 300 frames, about 1/2 the time "
       "and 2/3 the matrix dimension of the all-frames EIF.\n\n"
    << "| selector | buffer | frames used | state dim | time (s) | final pose error (m) | "
       "ATE (m) | mean NEES | NEES 95% band | inside ±2σ | BA ATE (m) | runs BA ≤ EIF |\n"
    << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char line[512];
  for (const TableRow& r : rows) {
    std::snprintf(
        line, sizeof(line),
        "| %s | %s | %.1f / %.0f | %.0f | %.3f | %.4f | %.4f | %.2f | [%.2f, %.2f] | %.1f%% | "
        "%.4f | %.0f%% |\n",
        r.selector.c_str(), r.buffer > 0 ? std::to_string(r.buffer).c_str() : "-", r.frames_used,
        r.frames_total, r.state_dim, r.seconds, r.final_pose_error_m, r.ate_rmse_m, r.mean_nees,
        r.nees_band.first, r.nees_band.second, 100.0 * r.within_2sigma, r.refined_ate_rmse_m,
        100.0 * r.refined_not_worse);
    s << line;
  }
  if (rows.size() > 1 && rows[0].selector == "all") {
    s << "\nRatios to the all-frames EIF:\n\n| buffer | frames | time | state dim "
         "|\n|---|---|---|---|\n";
    for (size_t i = 1; i < rows.size(); ++i) {
      std::snprintf(line, sizeof(line), "| %d | %.2f | %.2f | %.2f |\n", rows[i].buffer,
                    rows[i].frames_used / rows[0].frames_used, rows[i].seconds / rows[0].seconds,
                    rows[i].state_dim / rows[0].state_dim);
      s << line;
    }
  }
  return s.str();
}

}  // namespace

int SimulateCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = {
      {"output", "OUT", "directory for table.md and report.json (required)"},
      {"runs", "N", "Monte-Carlo runs (default 1)"},
      {"seed", "S", "scene seed; run r draws its noise from seed S + r + 1 (default 1)"},
      {"buffers", "LIST", "look-ahead buffer sizes of the info rows (default 2,3,4,5)"},
      {"trajectory", "T", "polygon (the paper's) or rectangle (sharp 90 deg turns)"},
      {"config", "FILE", "options file (selector, filter and ba sections apply; --config of run)"},
      {"quiet", "", "no progress output"}};
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("simulate", "--output OUT [flags]",
                            "The paper's simulation: 300 poses on a two-loop 3-D trajectory among\n"
                            "2000 random features; the all-frames EIF against the information-\n"
                            "efficient selector (Table I), with NEES consistency over the runs;\n"
                            "each row's estimate is also bundle-adjusted (BA ATE).",
                            specs);
    return 0;
  }
  const std::string output = flags.Require("output");
  const int runs = flags.GetInt("runs", 1, 1, 10000);
  const uint32_t seed = static_cast<uint32_t>(flags.GetInt("seed", 1, 0, 2000000000));
  const std::vector<int> buffers = flags.GetIntList("buffers", {2, 3, 4, 5}, 1, 100);
  const std::string trajectory = flags.GetString("trajectory", "polygon");
  SimulationOptions simulation;
  if (trajectory == "rectangle") {
    simulation.trajectory.kind = SimulatedTrajectoryKind::kRectangle;
  } else if (trajectory != "polygon") {
    throw ConfigError("--trajectory must be polygon or rectangle, got '" + trajectory + "'");
  }
  simulation.scene_seed = seed;
  RunOptions options;  // the selector, filter and ba sections of --config
  if (flags.Has("config")) ApplyConfigFile(flags.Require("config"), &options);
  PrepareOutputDirectory(output);

  std::vector<SelectorOptions> rows_options;
  SelectorOptions all = options.selector;
  all.kind = SelectorKind::kAll;
  rows_options.push_back(all);
  for (int buffer : buffers) {
    SelectorOptions info = options.selector;
    info.kind = SelectorKind::kInfo;
    info.buffer_size = buffer;
    rows_options.push_back(info);
  }
  // Each row's metrics per run, kept light (the pose errors of the first run go into
  // first_run_errors); the table is their mean.
  std::vector<std::vector<KnownAssociationMetrics>> per_row(rows_options.size());
  // The first run's per-pose errors and sigmas of every row: the paper's Figs. 3-4.
  Json first_run_errors = Json::Array();
  Progress progress("simulate", runs * static_cast<int>(rows_options.size()), flags.Has("quiet"));
  // Ctrl-C: the table covers the runs completed (or the rows of the first run done); held
  // until the files are written, so that a Ctrl-C then does not lose them.
  const StopOnInterrupt interrupt;
  bool interrupted = false;
  for (int run = 0; run < runs && !interrupted; ++run) {
    interrupted = interrupt.requested();
    if (interrupted) break;
    simulation.noise_seed = seed + static_cast<uint32_t>(run) + 1;
    const SimulatedDataset data = SimulatePaperScenario(simulation);
    const KnownAssociationInput input{data.observations, data.T_w_c_true, data.camera};
    for (size_t i = 0; i < rows_options.size(); ++i) {
      interrupted = interrupt.requested();
      if (interrupted) break;
      KnownAssociationMetrics metrics =
          RunKnownAssociation(input, rows_options[i], options.filter, &options.ba);
      if (run == 0) first_run_errors.Push(PoseErrorsToJson(rows_options[i], metrics));
      metrics.pose_errors.clear();
      metrics.selection = SelectionResult();
      per_row[i].push_back(std::move(metrics));
      progress.Update(run * static_cast<int>(rows_options.size()) + static_cast<int>(i) + 1,
                      std::string(SelectorKindName(rows_options[i].kind)) + " " +
                          std::to_string(BufferOfRow(rows_options[i])));
    }
  }
  progress.Finish();
  // A run cut short is left out, unless it is the first: then its finished rows stand (none
  // when it was stopped before its first row).
  const size_t runs_done = per_row.back().empty() ? per_row.front().size() : per_row.back().size();
  std::vector<TableRow> rows;
  for (size_t i = 0; i < rows_options.size() && runs_done > 0; ++i) {
    if (per_row[i].size() < runs_done) continue;
    TableRow row;
    row.selector = SelectorKindName(rows_options[i].kind);
    row.buffer = BufferOfRow(rows_options[i]);
    row.nees_band = NeesBand(6, static_cast<int>(runs_done));
    for (size_t r = 0; r < runs_done; ++r) Accumulate(per_row[i][r], 1.0 / runs_done, &row);
    rows.push_back(row);
  }

  Json report = Json::Object()
                    .Set("version", IESLAM_VERSION)
                    .Set("runs", static_cast<int>(runs_done))
                    .Set("interrupted", interrupted)
                    .Set("seed", static_cast<int64_t>(seed))
                    .Set("trajectory", trajectory);
  report["options"].Set("buffers", Json::ArrayOf(buffers));
  report["options"].Set("config", flags.GetString("config", ""));
  report["options"].Set("runs", runs);  // asked for; "runs" above: those the table covers
  report["options"].Set("selector", SelectorOptionsToJson(options.selector));
  report["options"].Set("filter", FilterOptionsToJson(options.filter));
  report["options"].Set("ba", BaOptionsToJson(options.ba));
  Json table = Json::Array();
  for (const TableRow& row : rows) table.Push(RowToJson(row));
  report.Set("table", table);
  report.Set("first_run_pose_errors", first_run_errors);
  WriteTextAtomically(JoinPath(output, "report.json"), report.Dump() + "\n");
  const std::string markdown = TableMarkdown(rows, static_cast<int>(runs_done), seed, trajectory);
  WriteTextAtomically(JoinPath(output, "table.md"), markdown);
  std::cout << markdown;
  if (interrupted) {
    std::fprintf(stderr,
                 "simulate: interrupted; the table has %zu of %zu rows over %zu of %d run(s)\n",
                 rows.size(), rows_options.size(), runs_done, runs);
    return 130;
  }
  return 0;
}

}  // namespace ieslam
