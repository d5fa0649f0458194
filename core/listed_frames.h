// The frames of the timestamped dataset formats (tum, pair): a colour and a range
// `timestamp path` list (core/stamped_list.h) associated by timestamp, with ground truth
// attached to each frame.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/dataset.h"
#include "core/trajectory.h"

namespace ieslam {

// Frames of a timestamped format: the colour and range lists associated (AssociateStamps,
// within options.max_association_diff_s), ground truth from `ground_truth_path` attached when
// that file exists. Throws DataError for an empty list or when nothing associates.
std::vector<FrameInfo> ReadListedFrames(const std::string& colour_list,
                                        const std::string& range_list,
                                        const std::string& ground_truth_path,
                                        const DatasetOptions& options);

// The ground-truth pose at time t: interpolated between the two poses around t when both are
// within max_diff, else the nearest within max_diff, else none.
std::optional<Eigen::Isometry3d> GroundTruthAt(const Trajectory& ground_truth, double t,
                                               double max_diff);

}  // namespace ieslam
