#include "selection/pipeline/run_outputs.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <set>
#include <type_traits>
#include <utility>
#include <vector>

#include "backend/ba_problem_io.h"
#include "core/calibration.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/stopwatch.h"
#include "selection/pipeline/run_report.h"

namespace ieslam {
namespace {

// The information matrix's nonzero pattern at the level of state blocks, in state order: a
// line `blocks <kinds>` (one letter per block, P = pose, F = feature) and one line `i j` per
// nonzero off-diagonal block (i < j): the paper's Fig. 8. A feature couples with every pose
// that saw it (with delayed initialisation, the one that saw it first too, which comes before
// it in the state); pending features are not in it.
void WriteInformationBlocks(const InformationFilter& filter, const std::string& path) {
  std::vector<std::pair<int, char>> starts;  // state blocks in state order
  for (int frame : filter.frame_ids()) {
    starts.emplace_back(filter.StateIndex(VariableRef::Pose(frame)), 'P');
  }
  for (int64_t id : filter.feature_ids()) {
    starts.emplace_back(filter.StateIndex(VariableRef::Feature(id)), 'F');
  }
  std::sort(starts.begin(), starts.end());
  std::vector<int> block_of(filter.state_dim(), -1);
  std::string kinds;
  for (size_t b = 0; b < starts.size(); ++b) {
    const int size = starts[b].second == 'P' ? 6 : 3;
    for (int i = 0; i < size; ++i) block_of[starts[b].first + i] = static_cast<int>(b);
    kinds += starts[b].second;
  }
  std::set<std::pair<int, int>> pairs;
  const auto upper = filter.information_upper();
  for (int col = 0; col < upper.outerSize(); ++col) {
    for (std::decay_t<decltype(upper)>::InnerIterator it(upper, col); it; ++it) {
      const int a = block_of[it.row()], b = block_of[col];
      if (a != b && a >= 0 && b >= 0 && it.value() != 0.0) {
        pairs.emplace(std::min(a, b), std::max(a, b));
      }
    }
  }
  WriteFileAtomically(path, [&](std::ostream& out) {
    out << "# ieslam: nonzero blocks of the final information matrix, state order (P pose, F "
           "feature)\n";
    out << "blocks " << kinds << "\n";
    for (const auto& [a, b] : pairs) out << a << ' ' << b << "\n";
  });
}

std::string SelectedFramesText(const Dataset& dataset, const std::vector<int>& selected) {
  std::string lines;
  for (int frame : selected) {
    char line[64];
    std::snprintf(line, sizeof(line), "%d %.6f\n", dataset.info(frame).source_index,
                  dataset.info(frame).timestamp);
    lines += line;
  }
  return lines;
}

void RemoveOutput(const std::string& path) {
  std::error_code ec;
  std::filesystem::remove(path, ec);
  if (ec) throw OutputError("cannot remove " + path + " of an earlier run: " + ec.message());
}

}  // namespace

const std::vector<std::string>& RunOutputNames() {
  static const std::vector<std::string> names = {
      "keyframes.tum",        "trajectory.tum",
      "selected_frames.txt",  "groundtruth.tum",
      "ba_problem.txt",       "information_blocks.txt",
      "refined.tum",          "map.ply",
      "report.json",          "refine_report.json",
      "refine_refined.tum",   "map/map.bin",
      "corrected_calib.yaml", "refine_corrected_calib.yaml"};
  return names;
}

void WriteRunOutputs(const std::string& out, const Dataset& dataset, const RunOptions& options,
                     const RunResult& run, const std::function<bool()>& stop) {
  const auto outputs_start = std::chrono::steady_clock::now();
  const PipelineResult& p = run.pipeline;
  RemoveStaleTempFiles(out, RunOutputNames());
  const std::string map_dir = JoinPath(out, kMapDirectory);
  RemoveStaleTempFiles(map_dir, {kMapFileName});
  // Files of the set this run does not write are an earlier run's only where one was: a
  // directory that held no run keeps them (they are the user's).
  const std::string marker = JoinPath(out, kRunOutputMarker);
  std::error_code ec;
  const bool earlier_run = std::filesystem::exists(JoinPath(out, "report.json"), ec) ||
                           std::filesystem::exists(marker, ec);
  WriteTextAtomically(marker, "ieslam run outputs\n");
  RemoveOutput(JoinPath(out, "report.json"));
  // The calibration this run read may sit in OUT under an output's name (a second pass of a
  // depth correction, `--calib OUT/corrected_calib.yaml`): it is neither removed nor replaced.
  const auto read_this_run = [&](const std::string& name) {
    return std::filesystem::equivalent(JoinPath(out, name), dataset.calibration_path(), ec);
  };
  const bool calibration_in_the_way =
      run.corrected_calibration.has_value() && read_this_run("corrected_calib.yaml");
  std::set<std::string> written = {"keyframes.tum", "trajectory.tum", "selected_frames.txt",
                                   "report.json"};
  if (dataset.has_ground_truth()) written.insert("groundtruth.tum");
  if (p.has_estimate) written.insert({"ba_problem.txt", "information_blocks.txt"});
  if (run.refined()) written.insert("refined.tum");
  if (run.corrected_calibration && !calibration_in_the_way) written.insert("corrected_calib.yaml");
  if (run.map) written.insert("map.ply");
  if (run.saved_map) written.insert(std::string(kMapDirectory) + "/" + kMapFileName);
  for (const std::string& name : RunOutputNames()) {
    if (earlier_run && !written.count(name) && !read_this_run(name)) {
      RemoveOutput(JoinPath(out, name));
    }
  }
  WriteTumTrajectory(JoinPath(out, "keyframes.tum"), run.keyframes,
                     "ieslam keyframes (filter estimate)");
  WriteTumTrajectory(JoinPath(out, "trajectory.tum"), run.trajectory,
                     "ieslam every processed frame");
  WriteTextAtomically(JoinPath(out, "selected_frames.txt"),
                      SelectedFramesText(dataset, p.selection.selected));
  if (dataset.has_ground_truth()) {
    WriteTumTrajectory(JoinPath(out, "groundtruth.tum"), run.ground_truth, "ground truth");
  }
  if (p.has_estimate) {
    // So that `ieslam refine` can refine this run again later.
    WriteBaProblem(JoinPath(out, "ba_problem.txt"),
                   {p.problem, dataset.rig().colour, run.timestamps});
    WriteInformationBlocks(*p.filter, JoinPath(out, "information_blocks.txt"));
  }
  if (run.refined()) {
    WriteTumTrajectory(JoinPath(out, "refined.tum"),
                       RefinedTrajectory(*p.refinement, run.timestamps),
                       "ieslam bundle-adjusted keyframes");
  }
  if (written.count("corrected_calib.yaml")) {
    WriteCalibration(JoinPath(out, "corrected_calib.yaml"), *run.corrected_calibration);
  }
  if (run.map) run.map->WritePly(JoinPath(out, "map.ply"));
  if (run.saved_map) {
    std::error_code ec;
    std::filesystem::create_directories(map_dir, ec);
    if (ec) throw OutputError("cannot create " + map_dir + ": " + ec.message());
    WriteSavedMap(map_dir, *run.saved_map);
  }
  Json report =
      RunReport(dataset, options, run, SecondsSince(run.started), SecondsSince(outputs_start));
  if (calibration_in_the_way) {
    report["warnings"].Push(
        "corrected_calib.yaml is the calibration this run read: not replaced (its correction "
        "is in filter_vs_smoother.depth_correction)");
  }
  if (stop && stop()) report.Set("interrupted", true);
  WriteTextAtomically(JoinPath(out, "report.json"), report.Dump() + "\n");
}

}  // namespace ieslam
