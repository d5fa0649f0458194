// The file side of the evaluation (declared in backend/evaluation/evaluation.h): reading
// trajectories as TUM's scripts read them, and the text and JSON forms of a result. The JSON is
// written by hand: it is one fixed, flat shape and does not justify a dependency.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "backend/evaluation/evaluation.h"
#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {
namespace {

// Shortest text that reads back to the same double; JSON has no NaN or infinity, so those
// (which the evaluation does not produce) become null rather than an unreadable file.
std::string JsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  if (ec != std::errc()) return "null";
  return std::string(buffer, end);
}

std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\u%04x", static_cast<unsigned>(c));
      out += escaped;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// The six statistics as members of an object that is already open; `indent` is the
// members' indentation.
void WriteStatsMembers(const ErrorStats& stats, const std::string& indent, std::ostream& out) {
  out << indent << "\"rmse\": " << JsonNumber(stats.rmse) << ",\n"
      << indent << "\"mean\": " << JsonNumber(stats.mean) << ",\n"
      << indent << "\"median\": " << JsonNumber(stats.median) << ",\n"
      << indent << "\"std\": " << JsonNumber(stats.std) << ",\n"
      << indent << "\"min\": " << JsonNumber(stats.min) << ",\n"
      << indent << "\"max\": " << JsonNumber(stats.max) << "\n";
}

void AppendLine(const std::string& key, double value, std::string* out) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f", value);
  *out += key + " " + buffer + "\n";
}

}  // namespace

Trajectory ReadTumTrajectoryForEvaluation(const std::string& path,
                                          std::vector<std::string>* warnings) {
  RequireFile(path, "trajectory file");
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

std::string FormatEvaluation(const EvaluationResult& result) {
  std::string out;
  out += "ate.pairs " + std::to_string(result.ate.translation.count) + "\n";
  AppendLine("ate.rmse", result.ate.translation.rmse, &out);
  AppendLine("ate.mean", result.ate.translation.mean, &out);
  AppendLine("ate.median", result.ate.translation.median, &out);
  AppendLine("ate.std", result.ate.translation.std, &out);
  AppendLine("ate.min", result.ate.translation.min, &out);
  AppendLine("ate.max", result.ate.translation.max, &out);
  out += "rpe.pairs " + std::to_string(result.rpe.translation.count) + "\n";
  AppendLine("rpe.trans.rmse", result.rpe.translation.rmse, &out);
  AppendLine("rpe.rot.rmse", result.rpe.rotation.rmse, &out);
  return out;
}

std::string EvaluationToJson(const EvaluationResult& result) {
  const EvaluationOptions& options = result.options;
  std::ostringstream out;
  out << "{\n  \"ate\": {\n    \"pairs\": " << result.ate.translation.count << ",\n";
  WriteStatsMembers(result.ate.translation, "    ", out);
  out << "  },\n  \"rpe\": {\n    \"pairs\": " << result.rpe.translation.count << ",\n"
      << "    \"trans\": {\n";
  WriteStatsMembers(result.rpe.translation, "      ", out);
  out << "    },\n    \"rot\": {\n";
  WriteStatsMembers(result.rpe.rotation, "      ", out);
  out << "    }\n  },\n  \"options\": {\n"
      << "    \"max_diff_s\": " << JsonNumber(options.max_diff_s) << ",\n"
      << "    \"offset_s\": " << JsonNumber(options.offset_s) << ",\n"
      << "    \"scale\": " << JsonNumber(options.scale) << ",\n"
      << "    \"delta\": " << JsonNumber(options.delta) << ",\n"
      << "    \"delta_unit\": " << JsonString(DeltaUnitName(options.delta_unit)) << "\n"
      << "  }\n}\n";
  return out.str();
}

}  // namespace ieslam
