// Datasets: a sequence of colour + range frames with a calibrated rig and optional ground
// truth, behind one interface. Frames are loaded lazily, one at a time: opening a
// 10,000-frame sequence reads only its lists, never its images.
//
// Formats (see README "Datasets"), each a subclass in its own file:
//  - tum:     TUM RGB-D (core/tum_dataset.h).
//  - 7scenes: Microsoft 7-Scenes (core/seven_scenes_dataset.h).
//  - pair:    a colour camera plus a separate range imager (the paper's package), each at
//             its own resolution, with calib.yaml in the directory (core/pair_dataset.h).
// Each file says where its format finds its calibration.
//
// Ground truth (tum, pair) is associated to each frame's colour timestamp: interpolated
// between the two poses around it when both are within max_ground_truth_diff_s, else the
// nearest within that tolerance, else none (core/listed_frames.h).
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/option_table.h"
#include "core/trajectory.h"

namespace ieslam {

struct FrameInfo {
  int index = 0;           // position in the selected sequence (0 .. size-1)
  int source_index = 0;    // position in the dataset before first/last/stride selection
  double timestamp = 0.0;  // seconds
  std::string colour_path;
  std::string depth_path;
  std::optional<Eigen::Isometry3d> T_w_c_gt;  // ground truth of the colour camera, if known
};

struct Frame {
  FrameInfo info;
  cv::Mat colour;  // CV_8UC3, BGR, the colour camera's resolution
  cv::Mat depth;   // CV_32FC1 metres in the range imager's grid; 0 = no measurement
};

struct DatasetOptions {
  std::string format = "auto";            // auto | tum | 7scenes | pair
  std::string calib_file;                 // overrides the format's default calibration when set
  int first = 0;                          // first frame (in the dataset's own numbering)
  int last = -1;                          // last frame, inclusive; -1 = to the end
  int stride = 1;                         // take every stride-th frame
  double max_association_diff_s = 0.02;   // colour/range association (tum, pair)
  double max_ground_truth_diff_s = 0.02;  // frame to ground-truth pose association

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<DatasetOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

class Dataset {
 public:
  virtual ~Dataset() = default;

  virtual std::string format() const = 0;
  const std::string& directory() const { return directory_; }
  const Rig& rig() const { return rig_; }
  int size() const { return static_cast<int>(frames_.size()); }
  const FrameInfo& info(int i) const { return frames_.at(i); }
  bool has_ground_truth() const;
  // Frames in the dataset before first/last/stride selection.
  int total_frames() const { return total_frames_; }
  // The calibration file the rig was read from, and why it was chosen (for run reports;
  // a library does not print, so a guessed calibration is reported here).
  const std::string& calibration_path() const { return calibration_path_; }
  const std::string& calibration_source() const { return calibration_source_; }
  // How the calibration was chosen, one word for reports: "option" (DatasetOptions::calib_file),
  // "dataset file" (a calibration file inside the dataset), "directory name" (the sequence's
  // name names its camera), "format default" (the format has one camera) or "fallback" (a
  // guess, with a warning).
  const std::string& calibration_chosen_by() const { return calibration_chosen_by_; }
  // Things about the dataset a user should hear (a guessed calibration), one line each, for the
  // caller to print and report.
  const std::vector<std::string>& warnings() const { return warnings_; }

  // Reads frame i. Throws DataError naming the file for a missing, truncated or corrupt image or
  // one whose size does not match the calibration.
  Frame Load(int i) const;

  // Ground truth of the selected frames (those that have it), in frame order.
  Trajectory GroundTruth() const;

 protected:
  // Throws ConfigError for options failing DatasetOptions::Check: every format's
  // constructor takes the user's options through here first.
  Dataset(std::string directory, const DatasetOptions& options);
  // Applies first/last/stride (of the options the constructor checked) to the full frame
  // list and numbers the result. Throws DataError when `all` is empty or `first` lies
  // beyond its end.
  void SelectFrames(std::vector<FrameInfo> all, const DatasetOptions& options);

  std::string directory_;
  Rig rig_;
  std::vector<FrameInfo> frames_;
  int total_frames_ = 0;
  std::string calibration_path_;
  std::string calibration_source_;
  std::string calibration_chosen_by_;
  std::vector<std::string> warnings_;
  // DepthCorrectionDivisors(rig_.range), computed by the first Load (which may run on any
  // thread).
  mutable std::once_flag divisors_once_;
  mutable cv::Mat depth_divisors_;
};

// Detects the format of `directory` ("tum", "7scenes", "pair"); throws DataError when
// none matches, naming what was looked for.
std::string DetectDatasetFormat(const std::string& directory);

// Opens a dataset. Throws DataError (missing directory or lists, no frames, unsorted
// timestamps, ...) or ConfigError (bad options) with a message naming the file and value.
std::unique_ptr<Dataset> OpenDataset(const std::string& directory, const DatasetOptions& options);

// Each pixel's RangeImager::DepthCorrectionFactor (CV_32FC1, the imager's grid); empty when
// the imager has no correction.
cv::Mat DepthCorrectionDivisors(const RangeImager& range);

// A raw 16-bit range image (CV_16UC1) in metres as Dataset::Load returns it: CV_32FC1,
// RangeImager::RawToMetres per pixel (0 = no measurement), divided by the imager's depth
// correction factor. `divisors` (DepthCorrectionDivisors of `imager`), when given, saves
// computing them again.
cv::Mat RangeImageToMetres(const cv::Mat& raw, const RangeImager& imager,
                           const cv::Mat& divisors = cv::Mat());

}  // namespace ieslam
