#include "core/dataset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <regex>
#include <sstream>

#include <glog/logging.h>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "core/file_util.h"
#include "core/image_file.h"
#include "core/pair_dataset.h"
#include "core/seven_scenes_dataset.h"
#include "core/tum_dataset.h"

namespace ieslam {
namespace {

std::string SizeString(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// Reads an image, telling a missing file from one that is truncated or does not decode.
cv::Mat ReadImage(const std::string& path, int flags, const std::string& what, int frame) {
  const std::string prefix = "frame " + std::to_string(frame) + ": ";
  try {
    return ReadImageFile(path, flags, what);
  } catch (const DataError& e) {
    throw DataError(prefix + e.what());
  }
}

void RequireSize(const cv::Mat& image, const PinholeCamera& camera, const std::string& path,
                 const std::string& what, const std::string& rig_name, int frame) {
  if (image.cols != camera.width || image.rows != camera.height) {
    throw DataError("frame " + std::to_string(frame) + ": " + what + " " + path + " is " +
                    SizeString(image.cols, image.rows) + " but calibration '" + rig_name +
                    "' expects " + SizeString(camera.width, camera.height));
  }
}

bool IsFile(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

void RequireValid(const DatasetOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("dataset options: " + why);
}

void RequireDatasetDirectory(const std::string& directory) {
  std::error_code ec;
  if (!std::filesystem::exists(directory, ec)) {
    throw DataError("dataset directory not found: " + directory);
  }
  if (!std::filesystem::is_directory(directory, ec)) {
    throw DataError("dataset path is not a directory: " + directory);
  }
}

}  // namespace

const OptionTable<DatasetOptions>& DatasetOptions::Table() {
  static const OptionTable<DatasetOptions>* table = [] {
    using O = DatasetOptions;
    auto* t = new OptionTable<O>;
    t->Choice("format", &O::format, {"auto", "tum", "7scenes", "pair"}, "the dataset's layout");
    t->String("calib", &O::calib_file, "calibration file overriding the format's", "FILE");
    t->Int("first", &O::first, "first frame").Min(0);
    t->Int("last", &O::last, "last frame, inclusive (-1: the end)").Min(-1);
    t->Int("stride", &O::stride, "every N-th frame").Min(1);
    t->Double("max_association_diff_s", &O::max_association_diff_s,
              "colour/range association window (tum, pair)")
        .Above(0.0);
    t->Double("max_ground_truth_diff_s", &O::max_ground_truth_diff_s,
              "frame to ground-truth association window")
        .Above(0.0);
    t->Require([](const O& o) {
      return o.last == -1 || o.last >= o.first
                 ? std::string()
                 : "last must be -1 (to the end) or >= first (" + std::to_string(o.first) +
                       "), got " + std::to_string(o.last);
    });
    return t;
  }();
  return *table;
}

Dataset::Dataset(std::string directory, const DatasetOptions& options)
    : directory_(std::move(directory)) {
  RequireValid(options);
}

bool Dataset::has_ground_truth() const {
  return std::any_of(frames_.begin(), frames_.end(),
                     [](const FrameInfo& f) { return f.T_w_c_gt.has_value(); });
}

Frame Dataset::Load(int i) const {
  CHECK_GE(i, 0) << "frame index";
  CHECK_LT(i, size()) << "frame index";
  Frame frame;
  frame.info = frames_[i];
  const FrameInfo& info = frame.info;

  // Messages name the frame by its index in the dataset, as selected_frames.txt does.
  const int n = info.source_index;
  frame.colour = ReadImage(info.colour_path, cv::IMREAD_COLOR, "colour image", n);
  RequireSize(frame.colour, rig_.colour, info.colour_path, "colour image", rig_.name, n);

  const cv::Mat raw = ReadImage(info.depth_path, cv::IMREAD_UNCHANGED, "range image", n);
  if (raw.type() != CV_16UC1) {
    throw DataError("frame " + std::to_string(n) + ": range image " + info.depth_path +
                    " must be 16-bit single-channel, got " + std::to_string(raw.elemSize1() * 8) +
                    "-bit with " + std::to_string(raw.channels()) + " channel(s)");
  }
  RequireSize(raw, rig_.range.camera, info.depth_path, "range image", rig_.name, n);
  std::call_once(divisors_once_, [this] { depth_divisors_ = DepthCorrectionDivisors(rig_.range); });
  frame.depth = RangeImageToMetres(raw, rig_.range, depth_divisors_);
  return frame;
}

Trajectory Dataset::GroundTruth() const {
  Trajectory trajectory;
  for (const FrameInfo& f : frames_) {
    if (!f.T_w_c_gt) continue;
    TimedPose pose;
    pose.timestamp = f.timestamp;
    pose.T_w_c = *f.T_w_c_gt;
    trajectory.push_back(pose);
  }
  return trajectory;
}

void Dataset::SelectFrames(std::vector<FrameInfo> all, const DatasetOptions& options) {
  total_frames_ = static_cast<int>(all.size());
  if (all.empty()) throw DataError("no frames in dataset " + directory_);
  if (options.first >= total_frames_) {
    throw DataError("no frames selected: first = " + std::to_string(options.first) + " but " +
                    directory_ + " has " + std::to_string(total_frames_) + " frames (0.." +
                    std::to_string(total_frames_ - 1) + ")");
  }
  const int last = options.last < 0 ? total_frames_ - 1 : std::min(options.last, total_frames_ - 1);
  frames_.clear();
  for (int source = options.first; source <= last; source += options.stride) {
    FrameInfo info = std::move(all[source]);
    info.index = static_cast<int>(frames_.size());
    info.source_index = source;
    frames_.push_back(std::move(info));
  }
}

std::string DetectDatasetFormat(const std::string& directory) {
  RequireDatasetDirectory(directory);
  if (IsFile(JoinPath(directory, "rgb.txt")) && IsFile(JoinPath(directory, "depth.txt"))) {
    return "tum";
  }
  if (IsFile(JoinPath(directory, "colour.txt")) && IsFile(JoinPath(directory, "range.txt"))) {
    return "pair";
  }
  static const std::regex kSevenScenesDepth(R"(frame-\d+\.depth\.png)");
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(directory, ec)) {
    if (std::regex_match(entry.path().filename().string(), kSevenScenesDepth)) return "7scenes";
  }
  throw DataError("cannot tell the format of dataset " + directory +
                  ": looked for rgb.txt + depth.txt (tum), colour.txt + range.txt (pair) and "
                  "frame-NNNNNN.depth.png (7scenes)");
}

std::unique_ptr<Dataset> OpenDataset(const std::string& directory, const DatasetOptions& options) {
  RequireValid(options);
  RequireDatasetDirectory(directory);
  const std::string format =
      options.format == "auto" ? DetectDatasetFormat(directory) : options.format;
  if (format == "tum") return std::make_unique<TumDataset>(directory, options);
  if (format == "7scenes") return std::make_unique<SevenScenesDataset>(directory, options);
  return std::make_unique<PairDataset>(directory, options);
}

cv::Mat DepthCorrectionDivisors(const RangeImager& range) {
  if (!range.HasDepthCorrection()) return {};
  cv::Mat divisors(range.camera.height, range.camera.width, CV_32FC1);
  for (int y = 0; y < range.camera.height; ++y) {
    float* row = divisors.ptr<float>(y);
    for (int x = 0; x < range.camera.width; ++x) {
      const Eigen::Vector3d ray = range.camera.Unproject(Eigen::Vector2d(x, y));
      row[x] = static_cast<float>(range.DepthCorrectionFactor(ray.x(), ray.y()));
    }
  }
  return divisors;
}

cv::Mat RangeImageToMetres(const cv::Mat& raw, const RangeImager& imager, const cv::Mat& divisors) {
  CHECK_EQ(raw.type(), CV_16UC1);
  const cv::Mat own = divisors.empty() ? DepthCorrectionDivisors(imager) : cv::Mat();
  const cv::Mat& factor = divisors.empty() ? own : divisors;
  CHECK(factor.empty() || (factor.type() == CV_32FC1 && factor.size() == raw.size()));
  cv::Mat metres(raw.rows, raw.cols, CV_32FC1);
  for (int r = 0; r < raw.rows; ++r) {
    const uint16_t* in = raw.ptr<uint16_t>(r);
    float* out = metres.ptr<float>(r);
    for (int c = 0; c < raw.cols; ++c) out[c] = static_cast<float>(imager.RawToMetres(in[c]));
    if (factor.empty()) continue;
    // The range limits apply to the reading, as the sensor's own; the correction to what passed.
    const float* f = factor.ptr<float>(r);
    for (int c = 0; c < raw.cols; ++c) out[c] /= f[c];
  }
  return metres;
}

}  // namespace ieslam
