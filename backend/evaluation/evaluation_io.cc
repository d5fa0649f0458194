#include "backend/evaluation/evaluation_io.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/file_util.h"
#include "core/input_file.h"
#include "core/json.h"

namespace ieslam {
namespace {

// The six statistics of `stats` as members of `object`.
void SetStatsMembers(const ErrorStats& stats, Json* object) {
  object->Set("rmse", Json::BareDouble(stats.rmse))
      .Set("mean", Json::BareDouble(stats.mean))
      .Set("median", Json::BareDouble(stats.median))
      .Set("std", Json::BareDouble(stats.std))
      .Set("min", Json::BareDouble(stats.min))
      .Set("max", Json::BareDouble(stats.max));
}

void AppendLine(const std::string& key, double value, std::string* out) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f", value);
  *out += key + " " + buffer + "\n";
}

}  // namespace

Trajectory ReadTumTrajectoryForEvaluation(const std::string& path,
                                          std::vector<std::string>* warnings) {
  RequireRegularInputFile(path, "trajectory file", kMaxListFileBytes);
  std::ifstream in(path);
  if (!in) throw DataError("cannot open trajectory file " + path);
  return ParseTumTrajectoryForEvaluation(in, path, warnings);
}

Trajectory ParseTumTrajectoryForEvaluation(std::istream& in, const std::string& path,
                                           std::vector<std::string>* warnings) {
  Trajectory trajectory;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    trajectory.push_back(ParseTumPoseLine(line, path + ":" + std::to_string(line_number)));
  }
  // TUM's scripts key poses by stamp in a dict: the order of lines does not matter and a
  // repeated stamp keeps its last line. Real ground truth has such repeats (fr2_desk does).
  std::stable_sort(
      trajectory.begin(), trajectory.end(),
      [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  Trajectory unique;
  unique.reserve(trajectory.size());
  std::size_t repeats = 0;
  for (const TimedPose& pose : trajectory) {
    if (!unique.empty() && unique.back().timestamp == pose.timestamp) {
      unique.back() = pose;
      ++repeats;
    } else {
      unique.push_back(pose);
    }
  }
  if (repeats > 0 && warnings != nullptr) {
    warnings->push_back(path + ": " + std::to_string(repeats) +
                        " repeated timestamp(s); the last line of each is used, as TUM's "
                        "evaluate_ate.py / evaluate_rpe.py do");
  }
  return unique;
}

Trajectory AsReadBackFromTum(const Trajectory& trajectory, const std::string& name) {
  std::ostringstream text;
  for (const TimedPose& pose : trajectory) text << FormatTumLine(pose) << "\n";
  std::istringstream in(text.str());
  return ParseTumTrajectoryForEvaluation(in, name);
}

EvaluationResult EvaluateTrajectoryFiles(const std::string& gt_path, const std::string& est_path,
                                         const EvaluationOptions& options) {
  // Bad options are reported before the files are read, as by ComputeAte.
  std::string why;
  if (!options.Check(&why)) throw ConfigError("evaluation options: " + why);
  std::vector<std::string> warnings;
  const Trajectory gt = ReadTumTrajectoryForEvaluation(gt_path, &warnings);
  const Trajectory est = ReadTumTrajectoryForEvaluation(est_path, &warnings);
  EvaluationResult result = EvaluateTrajectories(gt, est, options, gt_path, est_path);
  result.warnings = std::move(warnings);
  return result;
}

std::string FormatEvaluation(const EvaluationResult& result) {
  std::string out;
  // What cannot be computed keeps its pairs line (how many pairs there were) and loses its
  // numbers; the reason is the caller's to print.
  out += "ate.pairs " + std::to_string(result.ate.translation.count) + "\n";
  if (result.ate_unavailable.empty()) {
    AppendLine("ate.rmse", result.ate.translation.rmse, &out);
    AppendLine("ate.mean", result.ate.translation.mean, &out);
    AppendLine("ate.median", result.ate.translation.median, &out);
    AppendLine("ate.std", result.ate.translation.std, &out);
    AppendLine("ate.min", result.ate.translation.min, &out);
    AppendLine("ate.max", result.ate.translation.max, &out);
  }
  out += "rpe.pairs " + std::to_string(result.rpe.translation.count) + "\n";
  if (result.rpe_unavailable.empty()) {
    AppendLine("rpe.trans.rmse", result.rpe.translation.rmse, &out);
    AppendLine("rpe.rot.rmse", result.rpe.rotation.rmse, &out);
  }
  return out;
}

std::string EvaluationToJson(const EvaluationResult& result) {
  const EvaluationOptions& options = result.options;
  Json ate = Json::Object();
  ate.Set("pairs", result.ate.translation.count);
  SetStatsMembers(result.ate.translation, &ate);
  Json trans = Json::Object();
  SetStatsMembers(result.rpe.translation, &trans);
  Json rot = Json::Object();
  SetStatsMembers(result.rpe.rotation, &rot);
  Json rpe = Json::Object();
  rpe.Set("pairs", result.rpe.translation.count).Set("trans", trans).Set("rot", rot);
  Json json_options = Json::Object();
  json_options.Set("max_diff_s", Json::BareDouble(options.max_diff_s))
      .Set("offset_s", Json::BareDouble(options.offset_s))
      .Set("scale", Json::BareDouble(options.scale))
      .Set("delta", Json::BareDouble(options.delta))
      .Set("delta_unit", DeltaUnitName(options.delta_unit));
  Json json = Json::Object();
  if (!result.ate_unavailable.empty())
    ate = Json::Object().Set("pairs", result.ate.translation.count);
  if (!result.rpe_unavailable.empty()) {
    rpe = Json::Object()
              .Set("pairs", result.rpe.translation.count)
              .Set("trans", Json())
              .Set("rot", Json());
  }
  json.Set("ate", ate).Set("rpe", rpe).Set("options", json_options);
  Json unavailable = Json::Object();
  if (!result.ate_unavailable.empty()) unavailable.Set("ate", result.ate_unavailable);
  if (!result.rpe_unavailable.empty()) unavailable.Set("rpe", result.rpe_unavailable);
  if (!unavailable.empty()) json.Set("unavailable", unavailable);
  return json.Dump() + "\n";
}

}  // namespace ieslam
