// Fuzzes the `timestamp path` list reader of the tum and pair formats and the association
// and ground-truth look-up that run on what it returns. The input is split at the first two
// NUL bytes into a colour list, a range list and a ground-truth trajectory.
//
// Besides crashes and sanitizer reports, aborts when an invariant the readers promise does
// not hold: lists strictly increasing and finite, each timestamp associated at most once and
// within the tolerance, interpolated ground truth a rigid motion.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/listed_frames.h"
#include "core/stamped_list.h"
#include "core/timestamp_association.h"
#include "core/trajectory.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

// Parses one list; false when the reader rejected it (a DataError is the correct answer).
bool Parse(const std::string& text, const std::string& name,
           std::vector<ieslam::StampedPath>* entries) {
  std::istringstream in(text);
  try {
    *entries = ieslam::ParseStampedList(in, name, "/data");
  } catch (const ieslam::DataError& e) {
    Require(std::string(e.what()).rfind(name + ":", 0) == 0);  // names the file and line
    return false;
  }
  for (size_t i = 0; i < entries->size(); ++i) {
    const ieslam::StampedPath& e = (*entries)[i];
    Require(std::isfinite(e.timestamp));
    Require(i == 0 || e.timestamp > (*entries)[i - 1].timestamp);
    Require(!e.path.empty() && e.line >= 1);
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t cut1 = input.find('\0');
  const size_t cut2 = cut1 == std::string::npos ? std::string::npos : input.find('\0', cut1 + 1);
  const std::string colour_text = input.substr(0, cut1);
  const std::string range_text =
      cut1 == std::string::npos ? "" : input.substr(cut1 + 1, cut2 - (cut1 + 1));
  const std::string gt_text = cut2 == std::string::npos ? "" : input.substr(cut2 + 1);

  std::vector<ieslam::StampedPath> colour, range;
  if (!Parse(colour_text, "rgb.txt", &colour) || !Parse(range_text, "depth.txt", &range)) return 0;
  std::vector<double> a, b;
  for (const auto& e : colour) a.push_back(e.timestamp);
  for (const auto& e : range) b.push_back(e.timestamp);
  constexpr double kMaxDiff = 0.02;
  const std::vector<ieslam::StampMatch> matches = ieslam::AssociateStamps(a, b, 0.0, kMaxDiff);
  std::set<size_t> used_a, used_b;
  for (const ieslam::StampMatch& m : matches) {
    const size_t i = m.first_index, j = m.second_index;
    Require(i < a.size() && j < b.size());
    Require(m.first_stamp == a[i] && m.second_stamp == b[j]);
    Require(used_a.insert(i).second && used_b.insert(j).second);
    Require(std::fabs(a[i] - b[j]) < kMaxDiff);
  }

  ieslam::Trajectory gt;
  std::istringstream gt_in(gt_text);
  try {
    gt = ieslam::ParseTumTrajectory(gt_in, "groundtruth.txt");
  } catch (const ieslam::DataError&) {
    return 0;
  }
  for (double t : a) {
    const auto pose = ieslam::GroundTruthAt(gt, t, kMaxDiff);
    if (!pose) continue;
    Require(pose->matrix().allFinite());
    const Eigen::Matrix3d R = pose->linear();
    Require((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6);
  }
  return 0;
}
