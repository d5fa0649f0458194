// The Python module `ieslam`: runs, datasets, evaluation and the simulation study of the
// library, with the command-line interface's options and numbers (README "Python").
//
// Every call that takes long (a run, a study, writing a run's files) releases the GIL; a run
// and a study poll Python's signal handlers between frames (rows), so that Ctrl-C stops them
// as it stops `ieslam run`, and raise the handler's exception (KeyboardInterrupt) once the
// library has returned.
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "apps/app_util.h"
#include "apps/option_flags.h"
#include "apps/python/python_convert.h"
#include "apps/python/python_dataset.h"
#include "apps/python/python_signals.h"
#include "backend/evaluation/evaluation.h"
#include "backend/evaluation/evaluation_io.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/stopwatch.h"
#include "core/version.h"
#include "selection/pipeline/dataset_run.h"
#include "selection/pipeline/localization.h"
#include "selection/pipeline/localization_outputs.h"
#include "selection/pipeline/refinement.h"
#include "selection/pipeline/run_outputs.h"
#include "selection/pipeline/run_report.h"
#include "selection/pipeline/simulation_study.h"

namespace py = pybind11;

namespace ieslam {
namespace {

// A finished run with what writing its files needs.
struct PythonRun {
  std::shared_ptr<const LoadedMap> map;  // mapped on from (the dataset refers to it), or null
  std::shared_ptr<const Dataset> dataset;
  RunOptions options;
  RunResult run;
  double total_seconds = 0.0;  // RunOnDataset's wall time

  // The frames of `keyframes`, in its (time) order, as CollectTrajectories orders them.
  std::vector<int> KeyframeIds() const {
    const PipelineResult& p = run.pipeline;
    std::vector<int> ids;
    for (const int frame : p.selection.selected) {
      if (p.T_w_c[frame]) ids.push_back(frame);
    }
    std::stable_sort(ids.begin(), ids.end(), [this](int a, int b) {
      return dataset->info(a).timestamp < dataset->info(b).timestamp;
    });
    return ids;
  }
  Json Report() const { return RunReport(*dataset, options, run, total_seconds, 0.0); }
};

// Sets the option of each keyword argument: a flag of `ieslam run` or `ieslam evaluate` with
// '_' for '-' (buffer=4, max_diff=0.05), or a top-level option of the registry.
template <typename R>
void ApplyOverrides(const OptionRegistry<R>& registry, const std::vector<OptionFlag>& flags,
                    const py::kwargs& overrides, const std::string& where, R* root) {
  for (const auto& item : overrides) {
    std::string key = py::str(item.first);
    std::string flag = key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    std::string name = key;
    for (const OptionFlag& f : flags) {
      if (f.flag == flag) name = f.option;
    }
    if (registry.Find(name) == nullptr) {
      std::string known;
      for (const OptionFlag& f : flags) {
        std::string arg = f.flag;
        std::replace(arg.begin(), arg.end(), '-', '_');
        known += (known.empty() ? "" : ", ") + arg;
      }
      throw ConfigError(where + ": unknown keyword argument '" + key + "' (one of " + known +
                        ", or options={...} with the keys `ieslam options` prints)");
    }
    registry.Set(root, name, OptionTextFromPython(item.second, key, where), where);
  }
}

// options: None, a dict ({"selector": {"buffer": 4}}) or the path of a config file; then
// the overrides, as `ieslam run`'s flags after its --config. Not checked as a whole (the
// dataset is the caller's to set).
void ApplyRunOptions(const py::object& options, const py::kwargs& overrides,
                     RunOptions* run_options, const std::string& command = "run") {
  if (py::isinstance<py::str>(options)) {
    ApplyConfigFile(options.cast<std::string>(), run_options);
  } else if (py::isinstance<py::dict>(options)) {
    ApplyOptionsDict(RunOptions::Registry(), options.cast<py::dict>(), "options", run_options);
  } else if (!options.is_none()) {
    throw ConfigError("options must be None, a dict or the path of a config file");
  }
  ApplyOverrides(RunOptions::Registry(),
                 command == "run" ? RunOptionFlags() : LocalizeOptionFlags(), overrides, command,
                 run_options);
}

// With `map` (a saved map's directory or its run's), mapping goes on from it as
// `ieslam run --map` does: its front-end options first.
std::shared_ptr<PythonRun> Run(const std::string& dataset, const py::object& options,
                               const py::object& map_arg, const py::kwargs& overrides) {
  auto result = std::make_shared<PythonRun>();
  if (!map_arg.is_none()) {
    const std::string path = map_arg.cast<std::string>();
    py::gil_scoped_release release;
    result->map = std::make_shared<const LoadedMap>(LoadMap(path));
    ApplyMapFrontEndOptions(result->map->map.options, result->map->file(), &result->options);
  }
  ApplyRunOptions(options, overrides, &result->options);
  result->options.dataset = dataset;
  std::string why;
  if (!result->options.Check(&why)) throw ConfigError(why);
  SignalPoll signals;
  {
    py::gil_scoped_release release;
    const std::shared_ptr<const Dataset> opened =
        OpenDataset(dataset, result->options.dataset_options);
    PipelineHooks hooks;
    hooks.stop = signals.Poll();
    if (result->map) {
      auto continued = std::make_shared<const ContinuedDataset>(*result->map, *opened,
                                                                result->options.dataset_options);
      result->dataset = continued;
      result->run = ContinueMapping(*continued, result->options, hooks);
    } else {
      result->dataset = opened;
      result->run = RunOnDataset(*result->dataset, result->options, hooks);
    }
    result->total_seconds = SecondsSince(result->run.started);
  }
  signals.RaiseIfStopped();
  return result;
}

// `ieslam localize` without its files: the map's front-end options, then `options`, then
// the overrides (its flags).
py::dict Localize(const std::string& map_arg, const std::string& dataset, const py::object& options,
                  const py::kwargs& overrides) {
  LoadedMap loaded;
  {
    py::gil_scoped_release release;
    loaded = LoadMap(map_arg);
  }
  const SavedMap& map = loaded.map;
  const std::string& map_dir = loaded.directory;
  RunOptions run_options;
  ApplyMapFrontEndOptions(map.options, loaded.file(), &run_options);
  ApplyRunOptions(options, overrides, &run_options, "localize");
  run_options.dataset = dataset;
  std::string why;
  if (!run_options.Check(&why)) throw ConfigError(why);
  const RunOptions used = run_options.Resolved();
  SignalPoll signals;
  std::unique_ptr<Dataset> data;
  LocalizeResult result;
  Json report;
  {
    py::gil_scoped_release release;
    data = OpenDataset(dataset, used.dataset_options);
    CheckMapCalibration(map, data->rig(), map_dir);
    LocalizeHooks hooks;
    hooks.stop = signals.Poll();
    result = LocalizeDataset(*data, map, used.source, used.localize, hooks);
    const MapFrameAlignment alignment = AlignMapToGroundTruth(map, result.refined_poses);
    report =
        LocalizeReport(*data, map_dir, map, used, result, alignment,
                       EvaluateLocalization(*data, result, alignment), loaded.load_seconds, 0.0);
  }
  signals.RaiseIfStopped();
  Trajectory placed;
  std::vector<std::string> how;
  for (const LocalizedFrame& f : result.frames) {
    how.push_back(!f.localized ? "no" : f.by_map ? "map" : "tracking");
    if (f.localized) placed.push_back({f.timestamp, f.T_map_c});
  }
  py::array_t<double> covariances(
      {static_cast<py::ssize_t>(placed.size()), py::ssize_t{6}, py::ssize_t{6}});
  auto c = covariances.mutable_unchecked<3>();
  py::ssize_t k = 0;
  for (const LocalizedFrame& f : result.frames) {
    if (!f.localized) continue;
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 6; ++j) c(k, i, j) = f.covariance(i, j);
    }
    ++k;
  }
  py::dict out;
  out["trajectory"] = TrajectoryToArray(placed);
  out["covariances"] = covariances;
  out["placed"] = how;
  out["report"] = JsonToPython(report);
  return out;
}

py::dict ErrorStatsToDict(const ErrorStats& stats) {
  py::dict d;
  d["pairs"] = stats.count;
  d["rmse"] = stats.rmse;
  d["mean"] = stats.mean;
  d["median"] = stats.median;
  d["std"] = stats.std;
  d["min"] = stats.min;
  d["max"] = stats.max;
  return d;
}

// A trajectory argument: a TUM file's path (read as `ieslam evaluate` reads it) or an array.
Trajectory TrajectoryArgument(const py::object& value, const std::string& name,
                              std::vector<std::string>* warnings) {
  if (py::isinstance<py::str>(value)) {
    return ReadTumTrajectoryForEvaluation(value.cast<std::string>(), warnings);
  }
  return ArrayToTrajectory(value.cast<py::array_t<double, py::array::c_style>>(), name);
}

py::dict Evaluate(const py::object& gt, const py::object& est, const py::kwargs& overrides) {
  EvaluationOptions options;
  ApplyOverrides(EvaluationRegistry(), EvaluateOptionFlags(), overrides, "evaluate", &options);
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  std::vector<std::string> warnings;
  const std::string gt_name = py::isinstance<py::str>(gt) ? gt.cast<std::string>() : "gt";
  const std::string est_name = py::isinstance<py::str>(est) ? est.cast<std::string>() : "est";
  const Trajectory gt_trajectory = TrajectoryArgument(gt, gt_name, &warnings);
  const Trajectory est_trajectory = TrajectoryArgument(est, est_name, &warnings);
  EvaluationResult result;
  {
    py::gil_scoped_release release;
    result = EvaluateTrajectories(gt_trajectory, est_trajectory, options, gt_name, est_name);
  }
  warnings.insert(warnings.end(), result.warnings.begin(), result.warnings.end());

  py::dict out;
  // `ieslam evaluate`'s lines as numbers (unrounded) and as the text it prints.
  py::dict values;
  values["ate.pairs"] = result.ate.translation.count;
  if (result.ate_unavailable.empty()) {
    const ErrorStats& ate = result.ate.translation;
    values["ate.rmse"] = ate.rmse;
    values["ate.mean"] = ate.mean;
    values["ate.median"] = ate.median;
    values["ate.std"] = ate.std;
    values["ate.min"] = ate.min;
    values["ate.max"] = ate.max;
  }
  values["rpe.pairs"] = result.rpe.translation.count;
  if (result.rpe_unavailable.empty()) {
    values["rpe.trans.rmse"] = result.rpe.translation.rmse;
    values["rpe.rot.rmse"] = result.rpe.rotation.rmse;
  }
  out["values"] = values;
  out["text"] = FormatEvaluation(result);
  out["ate"] = ErrorStatsToDict(result.ate.translation);
  out["rpe_trans"] = ErrorStatsToDict(result.rpe.translation);
  out["rpe_rot_deg"] = ErrorStatsToDict(result.rpe.rotation);
  // One row per associated pair: gt t, est t, error (m); for plotting the ATE over time.
  py::array_t<double> pairs({static_cast<py::ssize_t>(result.ate.pairs.size()), py::ssize_t{3}});
  auto p = pairs.mutable_unchecked<2>();
  for (size_t i = 0; i < result.ate.pairs.size(); ++i) {
    p(i, 0) = result.ate.pairs[i].gt_timestamp;
    p(i, 1) = result.ate.pairs[i].est_timestamp;
    p(i, 2) = result.ate.pairs[i].error;
  }
  out["ate_pairs"] = pairs;
  out["aligned_estimate"] = TrajectoryToArray(result.aligned_estimate);
  out["ate_unavailable"] = result.ate_unavailable;
  out["rpe_unavailable"] = result.rpe_unavailable;
  out["warnings"] = warnings;
  out["json"] = py::module_::import("json").attr("loads")(EvaluationToJson(result));
  return out;
}

// The paper's simulation study (`ieslam simulate`): options as its flags, and the selector,
// filter and ba sections of a run's options (a dict or a config file, as its --config).
py::dict Simulate(int runs, uint32_t seed, const std::vector<int>& buffers,
                  const std::string& trajectory, int poses, const py::object& options) {
  SimulationStudyOptions study;
  study.runs = runs;
  study.seed = seed;
  study.buffers = buffers;
  study.simulation.trajectory.num_poses = poses;
  if (trajectory == "rectangle") {
    study.simulation.trajectory.kind = SimulatedTrajectoryKind::kRectangle;
  } else if (trajectory != "polygon") {
    throw ConfigError("simulate: trajectory must be polygon or rectangle, got '" + trajectory +
                      "'");
  }
  RunOptions config = StudyRunOptions();  // without the observation gate, as `ieslam simulate`
  ApplyRunOptions(options, py::kwargs(), &config);
  study.selector = config.pipeline.selector;
  study.filter = config.pipeline.filter;
  study.ba = config.pipeline.ba;
  std::string why;
  if (!study.Check(&why)) throw ConfigError(why);
  SignalPoll signals;
  SimulationStudy result;
  {
    py::gil_scoped_release release;
    result = RunSimulationStudy(study, nullptr, signals.Poll());
  }
  signals.RaiseIfStopped();
  py::dict out;
  out["table"] = JsonToPython(StudyRowsToJson(result.rows));
  out["markdown"] = StudyMarkdown(result, study);
  out["runs_done"] = result.runs_done;
  out["pose_errors"] = JsonToPython(result.first_run_pose_errors);
  return out;
}

py::object OrNone(double value) { return value >= 0.0 ? py::cast(value) : py::none(); }

void BindModule(py::module_& m) {
  m.doc() = "ieslam: RGB-D SLAM with information-efficient keyframe selection (README \"Python\")";
  m.attr("__version__") = IeslamVersion();
  // Bad options are bad values, as for the command line's exit code 2.
  py::register_exception<ConfigError>(m, "ConfigError", PyExc_ValueError);
  py::register_exception<DataError>(m, "DataError", PyExc_Exception);
  py::register_exception<OutputError>(m, "OutputError", PyExc_OSError);

  BindDataset(m);

  py::class_<PythonRun, std::shared_ptr<PythonRun>>(m, "RunResult",
                                                    "What ieslam.run returns, in memory.")
      .def_property_readonly(
          "trajectory", [](const PythonRun& r) { return TrajectoryToArray(r.run.trajectory); },
          "N x 8 (t x y z qx qy qz qw): every placed frame (trajectory.tum)")
      .def_property_readonly(
          "keyframes", [](const PythonRun& r) { return TrajectoryToArray(r.run.keyframes); },
          "K x 8: the filter's estimate of the selected frames, in time order (keyframes.tum)")
      .def_property_readonly(
          "ground_truth", [](const PythonRun& r) { return TrajectoryToArray(r.run.ground_truth); },
          "the dataset's ground truth of the frames (groundtruth.tum)")
      .def_property_readonly(
          "refined",
          [](const PythonRun& r) -> py::object {
            if (!r.run.refined()) return py::none();
            return TrajectoryToArray(
                RefinedTrajectory(*r.run.pipeline.refinement, r.run.timestamps));
          },
          "K x 8 bundle-adjusted keyframes (refined.tum) with refine, else None")
      .def_property_readonly(
          "refinement_failure",
          [](const PythonRun& r) -> py::object {
            if (!r.run.pipeline.refinement) return py::none();
            return py::cast(r.run.pipeline.refinement->failure);
          },
          "why the refinement is not used ('' when it is; None without refine)")
      .def_property_readonly("keyframe_ids", &PythonRun::KeyframeIds,
                             "the frames (0 .. frames-1) of the keyframes' rows")
      .def_property_readonly(
          "keyframe_source_ids",
          [](const PythonRun& r) { return SourceIndices(*r.dataset, r.KeyframeIds()); },
          "the keyframes' indices in the dataset (before first/last/stride)")
      .def_property_readonly(
          "selected", [](const PythonRun& r) { return r.run.pipeline.selection.selected; },
          "the selected frames in the order they were added")
      .def_property_readonly(
          "covariances",
          [](const PythonRun& r) {
            // K x 6 x 6, NaN for a keyframe without one (no covariance recovery).
            const std::vector<int> ids = r.KeyframeIds();
            py::array_t<double> c(
                {static_cast<py::ssize_t>(ids.size()), py::ssize_t{6}, py::ssize_t{6}});
            auto a = c.mutable_unchecked<3>();
            const auto& covariances = r.run.pipeline.estimate.pose_covariances;
            for (size_t k = 0; k < ids.size(); ++k) {
              const auto it = covariances.find(ids[k]);
              for (int i = 0; i < 6; ++i) {
                for (int j = 0; j < 6; ++j) {
                  a(k, i, j) = it == covariances.end() ? std::nan("") : it->second(i, j);
                }
              }
            }
            return c;
          },
          "K x 6 x 6 pose covariances of the keyframes' rows (the filter's, over the Euler\n"
          "6-vector); NaN where there is none")
      .def_property_readonly(
          "decisions",
          [](const PythonRun& r) {
            py::list decisions;
            for (const SelectionDecision& d : r.run.pipeline.selection.decisions) {
              py::dict item;
              item["candidates"] = d.candidates;
              item["gains"] = d.gains;
              item["map_gains"] = d.map_gains;
              item["added"] = d.added;
              item["reason"] = d.reason;
              decisions.append(item);
            }
            return decisions;
          },
          "the selector's decisions: candidates, gains (nats), frames added, reason")
      .def_property_readonly(
          "frames_skipped", [](const PythonRun& r) { return r.run.frames_skipped; },
          "(frame in the dataset, reason) of the frames not placed")
      .def_property_readonly(
          "ate_rmse_m",
          [](const PythonRun& r) {
            py::dict ate;
            ate["keyframes"] = OrNone(r.run.ate_keyframes_m);
            ate["trajectory"] = OrNone(r.run.ate_trajectory_m);
            ate["refined"] = OrNone(r.run.ate_refined_m);
            return ate;
          },
          "ATE RMSE (m) as ieslam evaluate gives it on the written files; None without")
      .def_property_readonly(
          "seconds", [](const PythonRun& r) { return JsonToPython(r.Report()["seconds"]); },
          "wall time per stage, as report.json's seconds (total: the run without writing)")
      .def_property_readonly(
          "report", [](const PythonRun& r) { return JsonToPython(r.Report()); },
          "report.json's content (its seconds without writing)")
      .def_property_readonly(
          "options", [](const PythonRun& r) { return JsonToPython(r.options.ToJson()); },
          "the options the run used, by section")
      .def_property_readonly("interrupted", [](const PythonRun& r) { return r.run.interrupted(); })
      .def_property_readonly("frames_processed",
                             [](const PythonRun& r) { return r.run.frames_processed(); })
      .def_property_readonly("warnings", [](const PythonRun& r) { return r.run.warnings; })
      .def_property_readonly("dataset", [](const PythonRun& r) { return r.dataset; })
      .def(
          "write",
          [](const PythonRun& r, const std::string& out) {
            py::gil_scoped_release release;
            PrepareOutputDirectory(out);
            WriteRunOutputs(out, *r.dataset, r.options, r.run);
          },
          py::arg("directory"),
          "Writes the files of `ieslam run --output DIRECTORY` (README) into the directory.")
      .def("__repr__", [](const PythonRun& r) {
        return "<ieslam.RunResult " + std::to_string(r.run.keyframes.size()) + " keyframes, " +
               std::to_string(r.run.trajectory.size()) + " frames>";
      });

  m.def("run", &Run, py::arg("dataset"), py::arg("options") = py::none(),
        py::arg("map") = py::none(),
        "Runs the pipeline on a dataset as `ieslam run` does. options: None, a dict of the\n"
        "registry's sections ({'selector': {'buffer': 4}, 'threads': 1}; `ieslam options`\n"
        "lists them) or a config file's path. map: a saved map to go on mapping from, as\n"
        "`ieslam run --map` (a run's output directory or its map/). Keyword arguments are the\n"
        "run's flags (threads=1, seed=3, refine=True, buffer=4, last=29, ...), applied after\n"
        "options. Raises ConfigError, DataError; KeyboardInterrupt on Ctrl-C.");
  m.def("localize", &Localize, py::arg("map"), py::arg("dataset"), py::arg("options") = py::none(),
        "Places each frame of a dataset in a saved map as `ieslam localize` does (map: a run's\n"
        "output directory or its map/). options as run's, over the map's front-end options;\n"
        "keyword arguments are localize's flags (threads=1, seed=3, first=250, ...). Returns\n"
        "{'trajectory': N x 8 (t, position, quaternion) of the placed frames in the map frame,\n"
        "'covariances': N x 6 x 6, 'placed': per frame 'map' | 'tracking' | 'no', 'report':\n"
        "report.json's content}. Raises ConfigError, DataError; KeyboardInterrupt on Ctrl-C.");
  m.def("evaluate", &Evaluate, py::arg("gt"), py::arg("est"),
        "ATE and RPE as `ieslam evaluate`: gt and est are TUM files' paths or N x 8 arrays;\n"
        "keyword arguments are its flags (max_diff=, offset=, scale=, delta=, delta_unit=).\n"
        "Returns a dict: values ({'ate.rmse': ...} as it prints them, unrounded), text (what\n"
        "it prints), ate / rpe_trans / rpe_rot_deg statistics, ate_pairs (gt t, est t, error\n"
        "per pair), aligned_estimate, warnings, json (evaluation.json).");
  m.def("simulate", &Simulate, py::arg("runs") = 1, py::arg("seed") = 1,
        py::arg("buffers") = std::vector<int>{2, 3, 4, 5}, py::arg("trajectory") = "polygon",
        py::arg("poses") = 300, py::arg("options") = py::none(),
        "The paper's simulation study as `ieslam simulate`: returns {'table': [row, ...],\n"
        "'markdown': table.md, 'runs_done', 'pose_errors'}; options as run's (its selector,\n"
        "filter and ba sections apply).");
}

}  // namespace
}  // namespace ieslam

PYBIND11_MODULE(ieslam, m) { ieslam::BindModule(m); }
