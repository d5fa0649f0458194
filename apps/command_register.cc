// `ieslam register`: registers frame i to i+K across a dataset and compares with ground truth.
#include <cstdio>
#include <iostream>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/json.h"
#include "frontend/pairwise_evaluation.h"

namespace ieslam {
namespace {

std::vector<FlagSpec> RegisterFlagSpecs() {
  std::vector<FlagSpec> specs = DatasetFlagSpecs();
  specs.push_back({"step", "K", "register frame i to frame i+K (required)"});
  specs.push_back({"output", "OUT", "directory for register.json (required)"});
  specs.push_back({"quiet", "", "no progress output"});
  return specs;
}

Json ReportToJson(const PairwiseReport& report, int step) {
  Json json = Json::Object()
                  .Set("step", step)
                  .Set("pairs", report.pairs.size())
                  .Set("success_rate", report.success_rate)
                  .Set("rot_err_median_deg", report.rotation_error_median_deg)
                  .Set("trans_err_median_m", report.translation_error_median_m)
                  .Set("rot_err_p90_deg", report.rotation_error_p90_deg)
                  .Set("trans_err_p90_m", report.translation_error_p90_m)
                  .Set("ms_per_frame", report.ms_per_frame)
                  .Set("interrupted", report.interrupted);
  Json pairs = Json::Array();
  for (const PairRecord& r : report.pairs) {
    Json pair = Json::Object()
                    .Set("a", r.frame_a)
                    .Set("b", r.frame_b)
                    .Set("success", r.success)
                    .Set("matches", r.matches)
                    .Set("inliers", r.inliers);
    if (r.registered) {
      pair.Set("trans_err_m", r.translation_error_m).Set("rot_err_deg", r.rotation_error_deg);
    } else {
      pair.Set("reason", r.reason);
    }
    pairs.Push(pair);
  }
  json.Set("pair_records", pairs);
  return json;
}

}  // namespace

int RegisterCommand(const CommandArgs& args) {
  const std::vector<FlagSpec> specs = RegisterFlagSpecs();
  const Flags flags(args, specs);
  if (flags.help()) {
    std::cout << FormatHelp("register", "--dataset DIR --step K --output OUT [flags]",
                            "Registers frame i to frame i+K for every i and compares the relative\n"
                            "pose with ground truth: the check of a calibration and front end.",
                            specs);
    return 0;
  }
  const std::string output = flags.Require("output");
  PairwiseOptions options;
  flags.Require("step");
  options.step = flags.GetInt("step", options.step, 1, 100000);
  const DatasetOptions dataset_options = DatasetOptionsFromFlags(flags);
  const auto dataset = OpenDataset(flags.Require("dataset"), dataset_options);
  WarnAboutDataset("register", *dataset);
  PrepareOutputDirectory(output);

  Progress progress("register", dataset->size() - options.step, flags.Has("quiet"));
  // Ctrl-C: the report covers the pairs done; held until it is written.
  const StopOnInterrupt interrupt;
  const PairwiseReport report = EvaluatePairwiseRegistration(
      *dataset, FrontendOptions(), options, [&progress](int done, int) { progress.Update(done); },
      interrupt.Poll());
  progress.Finish();

  const Json json = ReportToJson(report, options.step);
  WriteTextAtomically(JoinPath(output, "register.json"), json.Dump() + "\n");
  std::printf("register.pairs %zu\n", report.pairs.size());
  std::printf("register.success_rate %.6f\n", report.success_rate);
  std::printf("register.rot_err_median_deg %.6f\n", report.rotation_error_median_deg);
  std::printf("register.trans_err_median_m %.6f\n", report.translation_error_median_m);
  std::printf("register.rot_err_p90_deg %.6f\n", report.rotation_error_p90_deg);
  std::printf("register.trans_err_p90_m %.6f\n", report.translation_error_p90_m);
  std::printf("register.ms_per_frame %.6f\n", report.ms_per_frame);
  if (report.interrupted) {
    std::fprintf(stderr, "register: interrupted after %zu pairs; register.json covers those\n",
                 report.pairs.size());
    return interrupt.exit_code();
  }
  return 0;
}

}  // namespace ieslam
