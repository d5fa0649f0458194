// Internal to core/: the dataset formats behind OpenDataset, and the list helpers the
// timestamped formats (tum, pair) share. Users include core/dataset.h only.
#pragma once

#include <istream>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/dataset.h"
#include "core/trajectory.h"

namespace ieslam {

class TumDataset final : public Dataset {
 public:
  TumDataset(const std::string& directory, const DatasetOptions& options);
  std::string format() const override { return "tum"; }
};

class SevenScenesDataset final : public Dataset {
 public:
  SevenScenesDataset(const std::string& directory, const DatasetOptions& options);
  std::string format() const override { return "7scenes"; }
};

class PairDataset final : public Dataset {
 public:
  PairDataset(const std::string& directory, const DatasetOptions& options);
  std::string format() const override { return "pair"; }
};

// One entry of a TUM-style `timestamp path` list.
struct StampedPath {
  double timestamp = 0.0;
  std::string path;  // resolved against the list's directory
  int line = 0;      // 1-based line in the list, for messages
};

// Reads a `timestamp path` list (`#` comments and blank lines skipped). Throws DataError
// naming the file and line for a missing file, a malformed line, a non-finite timestamp,
// or timestamps that are not strictly increasing (unsorted or duplicate).
std::vector<StampedPath> ReadStampedList(const std::string& list_path);
// The same from a stream; `list_path` names it in messages, paths resolve against `directory`.
std::vector<StampedPath> ParseStampedList(std::istream& in, const std::string& list_path,
                                          const std::string& directory);

// Pairs timestamps of `a` and `b` as TUM's associate.py does: every pair closer than
// `max_diff` is a candidate; candidates are taken greedily by increasing |dt|, each
// timestamp used at most once. Both inputs sorted; the result is (index in a, index in b)
// sorted by a.
std::vector<std::pair<int, int>> AssociateTimestamps(const std::vector<double>& a,
                                                     const std::vector<double>& b, double max_diff);

// The ground-truth pose at time t (see core/dataset.h), or none.
std::optional<Eigen::Isometry3d> GroundTruthAt(const Trajectory& ground_truth, double t,
                                               double max_diff);

// Frames of a timestamped format: the colour and range lists associated, ground truth
// from `ground_truth_path` attached when that file exists. Throws DataError for an empty
// list or when nothing associates.
std::vector<FrameInfo> ReadListedFrames(const std::string& colour_list,
                                        const std::string& range_list,
                                        const std::string& ground_truth_path,
                                        const DatasetOptions& options);

// `path` if absolute, else `directory`/`path`.
std::string ResolvePath(const std::string& directory, const std::string& path);

}  // namespace ieslam
