// Timestamped lists shared by the tum and pair formats: reading, association, ground truth.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include "core/dataset_formats.h"
#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {

std::string ResolvePath(const std::string& directory, const std::string& path) {
  if (!path.empty() && path.front() == '/') return path;
  return JoinPath(directory, path);
}

std::vector<StampedPath> ReadStampedList(const std::string& list_path) {
  RequireFile(list_path, "image list");
  std::ifstream in(list_path);
  if (!in) throw DataError("cannot open image list " + list_path);
  return ParseStampedList(in, list_path, std::filesystem::path(list_path).parent_path().string());
}

std::vector<StampedPath> ParseStampedList(std::istream& in, const std::string& list_path,
                                          const std::string& directory) {
  std::vector<StampedPath> entries;
  std::string line;
  int line_number = 0;
  // Messages name the file and line, as compilers do: "rgb.txt:12: ...".
  const auto fail = [&](const std::string& problem) {
    throw DataError(list_path + ":" + std::to_string(line_number) + ": " + problem);
  };
  while (std::getline(in, line)) {
    ++line_number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, path;
    if (!(fields >> stamp >> path)) {
      fail("expected `timestamp path`, got: " + line);
    }
    char* end = nullptr;
    const double t = std::strtod(stamp.c_str(), &end);
    if (end == stamp.c_str() || *end != '\0' || !std::isfinite(t)) {
      fail("not a finite timestamp: " + stamp);
    }
    if (!entries.empty() && !(t > entries.back().timestamp)) {
      const StampedPath& previous = entries.back();
      std::ostringstream s;
      s.precision(6);
      if (t == previous.timestamp) {
        s << "duplicate timestamp " << stamp << " (also on line " << previous.line << ")";
      } else {
        s << std::fixed << "timestamps must increase strictly, got " << t << " after "
          << previous.timestamp << " on line " << previous.line;
      }
      fail(s.str());
    }
    entries.push_back({t, ResolvePath(directory, path), line_number});
  }
  return entries;
}

std::vector<std::pair<int, int>> AssociateTimestamps(const std::vector<double>& a,
                                                     const std::vector<double>& b,
                                                     double max_diff) {
  // Candidates come from a window around each a (both lists are sorted), so this is
  // O(n log n) where associate.py's all-pairs loop is O(n m).
  std::vector<std::tuple<double, int, int>> candidates;
  for (int i = 0; i < static_cast<int>(a.size()); ++i) {
    auto it = std::lower_bound(b.begin(), b.end(), a[i] - max_diff);
    for (; it != b.end() && *it < a[i] + max_diff; ++it) {
      const double dt = std::fabs(a[i] - *it);
      if (dt < max_diff) candidates.emplace_back(dt, i, static_cast<int>(it - b.begin()));
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_a(a.size(), false), used_b(b.size(), false);
  std::vector<std::pair<int, int>> matches;
  for (const auto& [dt, i, j] : candidates) {
    if (used_a[i] || used_b[j]) continue;
    used_a[i] = used_b[j] = true;
    matches.emplace_back(i, j);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
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
    // Motion capture runs at 100+ Hz, so a frame falls between two close poses:
    // interpolating removes up to half a sample period of lag (mm at hand-held speeds).
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
  const auto matches = AssociateTimestamps(colour_t, range_t, options.max_association_diff_s);
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
  for (const auto& [i, j] : matches) {
    FrameInfo info;
    info.timestamp = colour[i].timestamp;
    info.colour_path = colour[i].path;
    info.depth_path = range[j].path;
    info.T_w_c_gt = GroundTruthAt(ground_truth, info.timestamp, options.max_ground_truth_diff_s);
    frames.push_back(std::move(info));
  }
  return frames;
}

}  // namespace ieslam
