#include "selection/pipeline/simulation_shards.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "core/error.h"
#include "core/input_file.h"

namespace ieslam {
namespace {

// runs.tsv's value columns, after run, selector and buffer.
constexpr int kValueColumns = 12;
const char* const kColumns =
    "run\tselector\tbuffer\tframes_total\tframes_used\tstate_dim\tseconds\tseconds_selection\t"
    "seconds_filter\tfinal_pose_error_m\tate_rmse_m\tmean_nees\twithin_2sigma\t"
    "refined_ate_rmse_m\tseconds_ba";

double* ValueColumn(StudyRunValues* v, int i) {
  double* const columns[kValueColumns] = {
      &v->frames_total,      &v->frames_used,    &v->state_dim,          &v->seconds,
      &v->seconds_selection, &v->seconds_filter, &v->final_pose_error_m, &v->ate_rmse_m,
      &v->mean_nees,         &v->within_2sigma,  &v->refined_ate_rmse_m, &v->seconds_ba};
  return columns[i];
}

std::string JoinInts(const std::vector<int>& values) {
  std::string s;
  for (size_t i = 0; i < values.size(); ++i) s += (i > 0 ? "," : "") + std::to_string(values[i]);
  return s;
}

std::vector<std::string> SplitTabs(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, '\t')) fields.push_back(field);
  if (!line.empty() && line.back() == '\t') fields.emplace_back();
  return fields;
}

// Thrown for a malformed line of `path`.
DataError BadLine(const std::string& path, int line, const std::string& why) {
  return DataError(path + ":" + std::to_string(line) + ": " + why);
}

int ParseInt(const std::string& text, const std::string& path, int line) {
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0 || value < 0 || value > 2000000000L) {
    throw BadLine(path, line, "expected a non-negative integer, got '" + text + "'");
  }
  return static_cast<int>(value);
}

double ParseDouble(const std::string& text, const std::string& path, int line) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') {
    throw BadLine(path, line, "expected a number, got '" + text + "'");
  }
  return value;
}

}  // namespace

Json StudyOptionsJson(const SimulationStudyOptions& options) {
  return Json::Object()
      .Set("selector", SelectorOptions::Table().ToJson(options.selector))
      .Set("filter", InformationFilterOptions::Table().ToJson(options.filter))
      .Set("ba", BundleAdjustmentOptions::Table().ToJson(options.ba));
}

std::string StudyRunsTsv(const SimulationStudy& study, const SimulationStudyOptions& options) {
  std::ostringstream s;
  s << "# ieslam simulate: every run's values of every row, from which the table's means are "
       "computed\n"
    << "# seed\t" << options.seed << "\n"
    << "# trajectory\t" << ToString(options.simulation.trajectory.kind) << "\n"
    << "# poses\t" << options.simulation.trajectory.num_poses << "\n"
    << "# buffers\t" << JoinInts(options.buffers) << "\n"
    << "# options\t" << StudyOptionsJson(options).Dump(0) << "\n"
    << "# first_run\t" << study.first_run << "\n"
    << "# runs\t" << study.runs_done << "\n"
    << kColumns << "\n";
  char number[32];
  for (int r = 0; r < study.runs_done; ++r) {
    for (const StudyRowRuns& row : study.row_runs) {
      if (static_cast<int>(row.runs.size()) <= r) continue;
      s << study.first_run + r << "\t" << row.selector << "\t" << row.buffer;
      StudyRunValues v = row.runs[r];
      for (int i = 0; i < kValueColumns; ++i) {
        std::snprintf(number, sizeof(number), "%.17g", *ValueColumn(&v, i));
        s << "\t" << number;
      }
      s << "\n";
    }
  }
  return s.str();
}

namespace {

// One `# key<TAB>value` line of a runs file's header into the shard (`runs`: the run count it
// declares); a `#` line without a tab is a comment.
void ReadHeaderLine(const std::string& line, const std::string& path, int line_number,
                    StudyShard* shard, int* runs) {
  const size_t tab = line.find('\t');
  if (tab == std::string::npos) return;
  const std::string key = line.substr(2, tab - 2), value = line.substr(tab + 1);
  if (key == "seed") {
    shard->seed = static_cast<uint32_t>(ParseInt(value, path, line_number));
  } else if (key == "trajectory") {
    shard->trajectory = value;
  } else if (key == "poses") {
    shard->poses = ParseInt(value, path, line_number);
  } else if (key == "buffers") {
    std::istringstream list(value);
    std::string item;
    while (std::getline(list, item, ',')) {
      shard->buffers.push_back(ParseInt(item, path, line_number));
    }
  } else if (key == "options") {
    shard->options_json = value;
  } else if (key == "first_run") {
    shard->study.first_run = ParseInt(value, path, line_number);
  } else if (key == "runs") {
    *runs = ParseInt(value, path, line_number);
  }
}

}  // namespace

StudyShard ReadStudyRunsTsv(const std::string& path) {
  std::istringstream in(ReadInputFile(path, "simulate runs file", 1ull << 32));
  StudyShard shard;
  shard.path = path;
  std::string line;
  int line_number = 0;
  int runs = -1;
  bool have_columns = false;
  std::vector<std::pair<std::string, int>> row_keys;  // (selector, buffer) of run first_run
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    if (line[0] == '#') {
      ReadHeaderLine(line, path, line_number, &shard, &runs);
      continue;
    }
    if (!have_columns) {
      if (line != kColumns) throw BadLine(path, line_number, "not the columns of a runs file");
      have_columns = true;
      continue;
    }
    const std::vector<std::string> fields = SplitTabs(line);
    if (fields.size() != 3 + kValueColumns) {
      throw BadLine(path, line_number,
                    "expected " + std::to_string(3 + kValueColumns) + " fields, got " +
                        std::to_string(fields.size()) + " (truncated?)");
    }
    const int run = ParseInt(fields[0], path, line_number);
    const int buffer = ParseInt(fields[2], path, line_number);
    const size_t row_count = shard.buffers.size() + 1;  // the all-frames row, then info rows
    if (shard.study.row_runs.empty()) {
      shard.study.row_runs.resize(row_count);
      for (size_t i = 0; i < row_count; ++i) {
        shard.study.row_runs[i].selector = i == 0 ? "all" : "info";
        shard.study.row_runs[i].buffer = i == 0 ? 0 : shard.buffers[i - 1];
      }
    }
    // Lines come run by run, each run's rows in table order.
    size_t filled = 0;
    for (const StudyRowRuns& row : shard.study.row_runs) filled += row.runs.size();
    const size_t i = filled % row_count;
    const int expected_run = shard.study.first_run + static_cast<int>(filled / row_count);
    StudyRowRuns& row = shard.study.row_runs[i];
    if (run != expected_run || fields[1] != row.selector || buffer != row.buffer) {
      throw BadLine(path, line_number,
                    "expected run " + std::to_string(expected_run) + " row " + row.selector + " " +
                        std::to_string(row.buffer) + ", got run " + fields[0] + " row " +
                        fields[1] + " " + fields[2]);
    }
    StudyRunValues v;
    for (int c = 0; c < kValueColumns; ++c) {
      *ValueColumn(&v, c) = ParseDouble(fields[3 + c], path, line_number);
    }
    row.runs.push_back(v);
  }
  if (runs < 0 || shard.trajectory.empty() || shard.poses <= 0 || shard.buffers.empty() ||
      shard.options_json.empty() || !have_columns) {
    throw DataError(path + ": not a simulate runs file (header incomplete)");
  }
  for (const StudyRowRuns& row : shard.study.row_runs) {
    if (static_cast<int>(row.runs.size()) != runs) {
      throw DataError(path + ": truncated: the header says " + std::to_string(runs) +
                      " run(s), row " + row.selector + " " + std::to_string(row.buffer) + " has " +
                      std::to_string(row.runs.size()));
    }
  }
  if (runs > 0 && shard.study.row_runs.empty()) {
    throw DataError(path + ": truncated: the header says " + std::to_string(runs) +
                    " run(s), the file has none");
  }
  shard.study.runs_done = runs;
  return shard;
}

StudyShard MergeStudyShards(std::vector<StudyShard> shards) {
  if (shards.empty()) throw ConfigError("merge: no shards given");
  std::stable_sort(shards.begin(), shards.end(), [](const StudyShard& a, const StudyShard& b) {
    return a.study.first_run < b.study.first_run;
  });
  StudyShard merged = shards.front();
  const StudyShard& first = shards.front();
  for (size_t k = 1; k < shards.size(); ++k) {
    const StudyShard& shard = shards[k];
    auto differs = [&](const std::string& what, const std::string& mine,
                       const std::string& theirs) {
      throw DataError(shard.path + ": " + what + " " + mine + " differs from " + theirs + " in " +
                      first.path);
    };
    if (shard.seed != first.seed) {
      differs("seed", std::to_string(shard.seed), std::to_string(first.seed));
    }
    if (shard.trajectory != first.trajectory)
      differs("trajectory", shard.trajectory, first.trajectory);
    if (shard.poses != first.poses) {
      differs("poses", std::to_string(shard.poses), std::to_string(first.poses));
    }
    if (shard.buffers != first.buffers) {
      differs("buffers", JoinInts(shard.buffers), JoinInts(first.buffers));
    }
    if (shard.options_json != first.options_json) differs("options", "", "those");
    const int next = merged.study.first_run + merged.study.runs_done;
    if (shard.study.first_run != next) {
      throw DataError(shard.path + ": runs " + std::to_string(shard.study.first_run) + " to " +
                      std::to_string(shard.study.first_run + shard.study.runs_done - 1) +
                      (shard.study.first_run < next ? " overlap" : " leave a gap after") +
                      " the runs before it (up to " + std::to_string(next - 1) + ", " +
                      shards[k - 1].path + ")");
    }
    for (size_t i = 0; i < merged.study.row_runs.size(); ++i) {
      std::vector<StudyRunValues>& runs = merged.study.row_runs[i].runs;
      runs.insert(runs.end(), shard.study.row_runs[i].runs.begin(),
                  shard.study.row_runs[i].runs.end());
    }
    merged.study.runs_done += shard.study.runs_done;
  }
  merged.study.rows =
      MeanStudyRows(merged.study.row_runs, static_cast<size_t>(merged.study.runs_done));
  return merged;
}

}  // namespace ieslam
