#include "core/listed_frames.h"

#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "core/stamped_list.h"
#include "core/timestamp_association.h"

namespace ieslam {

std::vector<FrameInfo> ReadListedFrames(const std::string& colour_list,
                                        const std::string& range_list,
                                        const std::string& ground_truth_path,
                                        const DatasetOptions& options) {
  const std::vector<StampedPath> colour = ReadStampedList(colour_list);
  const std::vector<StampedPath> range = ReadStampedList(range_list);
  if (colour.empty()) throw DataError("no frames: " + colour_list + " lists no images");
  if (range.empty()) throw DataError("no frames: " + range_list + " lists no images");
  std::vector<double> colour_t, range_t;
  for (const StampedPath& e : colour) colour_t.push_back(e.timestamp);
  for (const StampedPath& e : range) range_t.push_back(e.timestamp);
  const std::vector<StampMatch> matches =
      AssociateStamps(colour_t, range_t, 0.0, options.max_association_diff_s);
  if (matches.empty()) {
    throw DataError("no frames: no timestamp of " + colour_list + " is within " +
                    std::to_string(options.max_association_diff_s) + " s of one of " + range_list);
  }
  Trajectory ground_truth;
  std::error_code ec;
  if (std::filesystem::is_regular_file(ground_truth_path, ec)) {
    ground_truth = ReadTumTrajectory(ground_truth_path);
  }
  std::vector<FrameInfo> frames;
  for (const StampMatch& match : matches) {
    FrameInfo info;
    info.timestamp = colour[match.first_index].timestamp;
    info.colour_path = colour[match.first_index].path;
    info.depth_path = range[match.second_index].path;
    info.T_w_c_gt = GroundTruthAt(ground_truth, info.timestamp, options.max_ground_truth_diff_s);
    frames.push_back(std::move(info));
  }
  return frames;
}

std::optional<Eigen::Isometry3d> GroundTruthAt(const Trajectory& ground_truth, double t,
                                               double max_diff) {
  const auto after =
      std::upper_bound(ground_truth.begin(), ground_truth.end(), t,
                       [](double time, const TimedPose& pose) { return time < pose.timestamp; });
  const TimedPose* hi = after != ground_truth.end() ? &*after : nullptr;
  const TimedPose* lo = after != ground_truth.begin() ? &*(after - 1) : nullptr;
  const bool lo_near = lo != nullptr && t - lo->timestamp <= max_diff;
  const bool hi_near = hi != nullptr && hi->timestamp - t <= max_diff;
  if (lo_near && hi_near) {
    // Motion capture runs faster than the cameras, so a frame falls between two close poses:
    // interpolating removes up to half a sample period of lag.
    const double alpha = (t - lo->timestamp) / (hi->timestamp - lo->timestamp);
    const Eigen::Quaterniond q0(lo->T_w_c.linear()), q1(hi->T_w_c.linear());
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q0.slerp(alpha, q1).normalized().toRotationMatrix();
    T.translation() = (1.0 - alpha) * lo->T_w_c.translation() + alpha * hi->T_w_c.translation();
    return T;
  }
  if (lo_near) return lo->T_w_c;
  if (hi_near) return hi->T_w_c;
  return std::nullopt;
}

}  // namespace ieslam
