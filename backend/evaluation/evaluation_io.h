// The file side of the trajectory evaluation (backend/evaluation/evaluation.h): reading
// trajectories as TUM's scripts read them, and the text and JSON forms of a result.
#pragma once

#include <istream>
#include <string>
#include <vector>

#include "backend/evaluation/evaluation.h"
#include "core/trajectory.h"

namespace ieslam {

// Reads a TUM trajectory as TUM's scripts do, which ReadTumTrajectory (strictly increasing
// stamps) is too strict for: lines may come in any order, and a repeated timestamp keeps its
// last line (the scripts store poses in a dict); each file with repeats adds a line to
// `warnings`. Malformed lines, non-finite values and far-from-unit quaternions throw DataError
// naming file and line, as in ReadTumTrajectory.
Trajectory ReadTumTrajectoryForEvaluation(const std::string& path,
                                          std::vector<std::string>* warnings = nullptr);
// The same from a stream; `path` names it in messages.
Trajectory ParseTumTrajectoryForEvaluation(std::istream& in, const std::string& path,
                                           std::vector<std::string>* warnings = nullptr);
// `trajectory` as ReadTumTrajectoryForEvaluation reads it back from the TUM file
// WriteTumTrajectory makes of it (values rounded as the file prints them), without a file:
// what a report's ATE must be computed on to equal `ieslam evaluate` on the written files.
// `name` names it in messages.
Trajectory AsReadBackFromTum(const Trajectory& trajectory, const std::string& name);

// Reads both files (ReadTumTrajectoryForEvaluation) and evaluates; errors name the files.
EvaluationResult EvaluateTrajectoryFiles(const std::string& gt_path, const std::string& est_path,
                                         const EvaluationOptions& options);

// The `key value` lines `ieslam evaluate` prints: ate.pairs, ate.rmse, ate.mean,
// ate.median, ate.std, ate.min, ate.max, rpe.pairs, rpe.trans.rmse, rpe.rot.rmse (degrees);
// 6 decimals, one line each, newline-terminated. The ate.* or rpe.* lines are left out when
// that error could not be computed (the result's *_unavailable says why).
std::string FormatEvaluation(const EvaluationResult& result);

// OUT/evaluation.json: {"ate": {"pairs", "rmse", "mean", "median", "std", "min", "max"},
// "rpe": {"pairs", "trans": {...}, "rot": {...}}, "options": {...}}; numbers round-trip.
// An error that could not be computed is null, with its reason in "unavailable": {"ate" or
// "rpe": why}.
std::string EvaluationToJson(const EvaluationResult& result);

}  // namespace ieslam
