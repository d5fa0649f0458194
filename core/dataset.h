// Datasets: a sequence of colour + range frames with a calibrated rig and optional ground
// truth, behind one interface. Frames are loaded lazily, one at a time: opening a
// 10,000-frame sequence reads only its lists, never its images.
//
// Formats (see README "Datasets"):
//  - tum:     TUM RGB-D (rgb.txt, depth.txt, optional groundtruth.txt); colour and depth
//             associated by nearest timestamp within 0.02 s as TUM's associate.py does.
//  - 7scenes: frame-NNNNNN.color.{png,jpg}, .depth.png, .pose.txt; frame i at i/30 s.
//  - pair:    a colour camera plus a separate range imager (the paper's package), each at
//             its own resolution, with calib.yaml in the directory. Layout:
//               calib.yaml       the rig (core/calibration.h); required unless
//                                DatasetOptions::calib_file is set
//               colour.txt       `timestamp path` lines (TUM style, `#` comments), colour images
//               range.txt        `timestamp path` lines, 16-bit PNG range images
//                                (raw * depth_scale = metres, as the rig says)
//               groundtruth.txt  optional, TUM trajectory of the colour camera (T_w_c)
//             Paths are relative to the directory; colour and range are associated by
//             nearest timestamp as for tum.
//
// Calibration: DatasetOptions::calib_file when set; otherwise tum uses calib.yaml in the
// directory if present, else data/calib/tum_fr{1,2,3}.yaml by the directory name
// (freiburg1/fr1, ...; tum_fr1 when the name says nothing: see calibration_source());
// 7scenes uses data/calib/7scenes.yaml with the depth intrinsics of the dataset's
// camera-intrinsics.txt when present; pair uses its calib.yaml.
//
// Ground truth (tum, pair) is associated to each frame's colour timestamp: interpolated
// between the two poses around it when both are within max_ground_truth_diff_s, else the
// nearest within that tolerance, else none.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
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
  double max_association_diff_s = 0.02;   // TUM rgb/depth association
  double max_ground_truth_diff_s = 0.02;  // frame to ground-truth pose association

  bool Check(std::string* why) const;
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

  // Reads frame i. Throws DataError naming the file for a missing or corrupt image or
  // one whose size does not match the calibration.
  Frame Load(int i) const;

  // Ground truth of the selected frames (those that have it), in frame order.
  Trajectory GroundTruth() const;

 protected:
  Dataset(std::string directory, Rig rig)
      : directory_(std::move(directory)), rig_(std::move(rig)) {}
  // Applies first/last/stride to the full frame list and numbers the result. Throws
  // DataError when `all` is empty or `first` lies beyond its end.
  void SelectFrames(std::vector<FrameInfo> all, const DatasetOptions& options);

  std::string directory_;
  Rig rig_;
  std::vector<FrameInfo> frames_;
  int total_frames_ = 0;
  std::string calibration_path_;
  std::string calibration_source_;
};

// Detects the format of `directory` ("tum", "7scenes", "pair"); throws DataError when
// none matches, naming what was looked for.
std::string DetectDatasetFormat(const std::string& directory);

// Opens a dataset. Throws DataError (missing directory or lists, no frames, unsorted
// timestamps, ...) or ConfigError (bad options) with a message naming the file and value.
std::unique_ptr<Dataset> OpenDataset(const std::string& directory, const DatasetOptions& options);

// A raw 16-bit range image (CV_16UC1) in metres as Dataset::Load returns it: CV_32FC1,
// RangeImager::RawToMetres per pixel (0 = no measurement).
cv::Mat RangeImageToMetres(const cv::Mat& raw, const RangeImager& imager);

}  // namespace ieslam
