// `ieslam register`: registers frame i to i+K across a dataset and compares with ground truth.
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "apps/app_util.h"
#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/json.h"
#include "frontend/pairwise_evaluation.h"
#include "selection/pipeline/pairwise_depth_evaluation.h"

namespace ieslam {
namespace {

std::vector<FlagSpec> RegisterFlagSpecs() {
  std::vector<FlagSpec> specs = DatasetFlagSpecs();
  specs.push_back({"step", "K", "register frame i to frame i+K (required)"});
  specs.push_back({"output", "OUT", "directory for register.json (required)"});
  specs.push_back({"dense", "",
                   "also align each pair's range images alone (point-to-plane, as the "
                   "refinement), started from the ground truth: where the depth's own optimum "
                   "lies"});
  specs.push_back({"quiet", "", "no progress output"});
  return specs;
}

Json Xyz(const Eigen::Vector3d& v) {
  return Json::ArrayOf(std::vector<double>{v.x(), v.y(), v.z()});
}

// The summary both evaluations share (the features' or the depth's report), after `json`'s own
// keys.
Json SummaryToJson(const PairErrorSummary& summary, size_t pairs, Json json) {
  return json.Set("pairs", pairs)
      .Set("success_rate", summary.success_rate)
      .Set("rot_err_median_deg", summary.rotation_error_median_deg)
      .Set("trans_err_median_m", summary.translation_error_median_m)
      .Set("rot_err_p90_deg", summary.rotation_error_p90_deg)
      .Set("trans_err_p90_m", summary.translation_error_p90_m)
      .Set("trans_err_mean_xyz_m", Xyz(summary.translation_error_mean_a))
      .Set("trans_err_rms_xyz_m", Xyz(summary.translation_error_rms_a));
}

// What each kind of pair counts, and whether it has a pose to compare.
void SetCounts(const PairRecord& r, Json* pair) {
  pair->Set("matches", r.matches).Set("inliers", r.inliers);
}
void SetCounts(const DepthPairRecord& r, Json* pair) {
  pair->Set("correspondences", r.correspondences);
}
bool Compared(const PairRecord& r) { return r.registered; }
bool Compared(const DepthPairRecord& r) { return r.aligned; }

// One record per pair, with its errors or why it has none.
template <typename Record>
Json PairRecordsToJson(const std::vector<Record>& records) {
  Json pairs = Json::Array();
  for (const Record& r : records) {
    Json pair = Json::Object().Set("a", r.frame_a).Set("b", r.frame_b).Set("success", r.success);
    SetCounts(r, &pair);
    if (Compared(r)) {
      pair.Set("trans_err_m", r.translation_error_m)
          .Set("rot_err_deg", r.rotation_error_deg)
          .Set("trans_err_xyz_m", Xyz(r.translation_error_a));
    } else {
      pair.Set("reason", r.reason);
    }
    pairs.Push(pair);
  }
  return pairs;
}

Json ReportToJson(const PairwiseReport& report, int step) {
  return SummaryToJson(report, report.pairs.size(), Json::Object().Set("step", step))
      .Set("ms_per_frame", report.ms_per_frame)
      .Set("interrupted", report.interrupted)
      .Set("pair_records", PairRecordsToJson(report.pairs));
}

Json DenseToJson(const DepthPairwiseReport& report) {
  return SummaryToJson(report, report.pairs.size(), Json::Object())
      .Set("interrupted", report.interrupted)
      .Set("pair_records", PairRecordsToJson(report.pairs));
}

// The summary's keys on stdout, each under `prefix`.
void PrintSummary(const std::string& prefix, const PairErrorSummary& summary, size_t pairs) {
  const char* p = prefix.c_str();
  std::printf("%spairs %zu\n", p, pairs);
  std::printf("%ssuccess_rate %.6f\n", p, summary.success_rate);
  std::printf("%srot_err_median_deg %.6f\n", p, summary.rotation_error_median_deg);
  std::printf("%strans_err_median_m %.6f\n", p, summary.translation_error_median_m);
  std::printf("%srot_err_p90_deg %.6f\n", p, summary.rotation_error_p90_deg);
  std::printf("%strans_err_p90_m %.6f\n", p, summary.translation_error_p90_m);
}

// The per-axis figures on stdout, each under `prefix`.
void PrintAxes(const std::string& prefix, const PairErrorSummary& summary) {
  const char* axes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    std::printf("%strans_err_mean_%s_m %.6f\n", prefix.c_str(), axes[i],
                summary.translation_error_mean_a[i]);
  }
  for (int i = 0; i < 3; ++i) {
    std::printf("%strans_err_rms_%s_m %.6f\n", prefix.c_str(), axes[i],
                summary.translation_error_rms_a[i]);
  }
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
  const std::string json_path = JoinPath(output, "register.json");

  Progress progress("register", dataset->size() - options.step, flags.Has("quiet"));
  // Ctrl-C: the report covers the pairs done; held until it is written.
  const StopOnInterrupt interrupt;
  const PairwiseReport report = EvaluatePairwiseRegistration(
      *dataset, FrontendOptions(), options, [&progress](int done, int) { progress.Update(done); },
      interrupt.Poll());
  progress.Finish();
  // Written before the dense alignment starts, so that a failure there loses none of it.
  Json json = ReportToJson(report, options.step);
  WriteTextAtomically(json_path, json.Dump() + "\n");
  PrintSummary("register.", report, report.pairs.size());
  std::printf("register.ms_per_frame %.6f\n", report.ms_per_frame);
  PrintAxes("register.", report);
  if (report.interrupted) {
    std::fprintf(stderr, "register: interrupted after %zu pairs; register.json covers those%s\n",
                 report.pairs.size(), flags.Has("dense") ? " (no dense alignment)" : "");
    return interrupt.exit_code();
  }
  if (!flags.Has("dense")) return 0;

  Progress dense_progress("register --dense", dataset->size() - options.step, flags.Has("quiet"));
  const DepthPairwiseReport dense = EvaluatePairwiseDepthAlignment(
      *dataset, options, RangeCloudOptions(), DepthAlignmentOptions(),
      [&dense_progress](int done, int) { dense_progress.Update(done); }, interrupt.Poll());
  dense_progress.Finish();
  json.Set("dense", DenseToJson(dense));
  WriteTextAtomically(json_path, json.Dump() + "\n");
  PrintSummary("register.dense.", dense, dense.pairs.size());
  PrintAxes("register.dense.", dense);
  if (dense.interrupted) {
    std::fprintf(stderr,
                 "register: the dense alignment was interrupted after %zu pairs; register.json's "
                 "\"dense\" covers those\n",
                 dense.pairs.size());
    return interrupt.exit_code();
  }
  return 0;
}

}  // namespace ieslam
