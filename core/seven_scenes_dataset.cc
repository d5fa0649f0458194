#include "core/seven_scenes_dataset.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include <Eigen/SVD>

#include "core/calibration.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/input_file.h"

namespace ieslam {
namespace {

constexpr double kFrameRateHz = 30.0;

// All whitespace-separated numbers of a small text file; DataError naming the file when a
// token is not a number.
std::vector<double> ReadNumbers(const std::string& path) {
  std::istringstream in(ReadInputFile(path, "7-Scenes text file", kMaxSmallTextBytes));
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      throw DataError(std::string(path).append(": not a number: ").append(token));
    }
    values.push_back(v);
  }
  return values;
}

bool AllFinite(const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

Eigen::Isometry3d ReadPose(const std::string& path) {
  const std::vector<double> m = ReadNumbers(path);
  if (m.size() != 16) {
    throw DataError(path + ": expected a 4x4 matrix (16 numbers), got " + std::to_string(m.size()));
  }
  // KinectFusion loses track on some frames of the full dataset and writes inf there.
  if (!AllFinite(m)) throw DataError(path + ": pose contains NaN or inf");
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) T(r, c) = m[4 * r + c];
  }
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  // KinectFusion's chained poses drift slightly from orthonormal (docs/frontend_notes.md),
  // so only a clearly non-rigid matrix (a scale, a shear) is rejected; the rest is projected
  // onto the nearest rotation below.
  const double error = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (error > 1e-2 || R.determinant() < 0.0 ||
      (T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6) {
    std::ostringstream s;
    s << path << ": pose is not rigid (|R^T R - I| = " << error << ", det R = " << R.determinant()
      << ", last row " << T.row(3) << ")";
    throw DataError(s.str());
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = svd.matrixU() * svd.matrixV().transpose();
  pose.translation() = T.topRightCorner<3, 1>();
  return pose;
}

// The depth camera's intrinsics from camera-intrinsics.txt into `camera` (size kept).
void ReadIntrinsicsFile(const std::string& path, PinholeCamera* camera) {
  const std::vector<double> k = ReadNumbers(path);
  if (k.size() != 9 || !AllFinite(k) || !(k[0] > 0.0) || !(k[4] > 0.0) || k[1] != 0.0 ||
      k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0) {
    throw DataError(path + ": expected a 3x3 camera matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  camera->fx = k[0];
  camera->cx = k[2];
  camera->fy = k[4];
  camera->cy = k[5];
}

struct FrameFiles {
  std::string colour;
  std::string depth;
  std::string pose;
};

}  // namespace

SevenScenesDataset::SevenScenesDataset(const std::string& directory, const DatasetOptions& options)
    : Dataset(directory, options) {
  const bool given = !options.calib_file.empty();
  calibration_path_ = given ? options.calib_file : DefaultCalibrationPath("7scenes");
  calibration_source_ = given ? "given calibration file" : "7-Scenes default";
  calibration_chosen_by_ = given ? "option" : "format default";
  rig_ = ReadCalibration(calibration_path_);
  const std::string intrinsics = JoinPath(directory, "camera-intrinsics.txt");
  std::error_code ec;
  if (!given && std::filesystem::is_regular_file(intrinsics, ec)) {
    ReadIntrinsicsFile(intrinsics, &rig_.range.camera);
    calibration_source_ += ", depth intrinsics from " + intrinsics;
  }

  static const std::regex kName(R"(frame-(\d{1,9})\.(color\.png|color\.jpg|depth\.png|pose\.txt))");
  std::map<int, FrameFiles> files;
  int png_colour = 0, jpg_colour = 0;
  for (const auto& entry : std::filesystem::directory_iterator(directory, ec)) {
    const std::string name = entry.path().filename().string();
    std::smatch match;
    if (!std::regex_match(name, match, kName)) continue;
    FrameFiles& f = files[std::stoi(match[1].str())];
    const std::string kind = match[2].str();
    const std::string path = JoinPath(directory, name);
    if (kind == "depth.png") {
      f.depth = path;
    } else if (kind == "pose.txt") {
      f.pose = path;
    } else {
      ++(kind == "color.png" ? png_colour : jpg_colour);
      // The original dataset's PNG wins over a JPEG copy.
      if (f.colour.empty() || kind == "color.png") f.colour = path;
    }
  }
  if (ec) throw DataError("cannot list dataset directory " + directory + ": " + ec.message());
  if (files.empty()) {
    throw DataError("no frames: no frame-NNNNNN.depth.png / .color.{png,jpg} in " + directory);
  }

  // A frame missing its colour or depth image keeps its place with the file's expected path:
  // Load reports it missing, so it is a counted skip as in the listed formats, not the end of
  // the run (nor of one that would never reach it).
  // A missing colour image is named as the sequence's other frames are.
  const std::string missing_colour = jpg_colour > png_colour ? ".color.jpg" : ".color.png";
  std::vector<FrameInfo> all;
  std::vector<std::string> pose_paths;
  for (const auto& [number, f] : files) {
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06d", number);
    FrameInfo info;
    info.timestamp = number / kFrameRateHz;
    info.colour_path =
        f.colour.empty() ? JoinPath(directory, std::string(stem) + missing_colour) : f.colour;
    info.depth_path =
        f.depth.empty() ? JoinPath(directory, std::string(stem) + ".depth.png") : f.depth;
    all.push_back(std::move(info));
    pose_paths.push_back(f.pose);
  }
  SelectFrames(std::move(all), options);
  // Poses are read for the selected frames only: a few hundred tiny files, and opening a
  // strided sequence should not pay for the frames it skips.
  int without_pose = 0;
  std::string first_without_pose;
  for (FrameInfo& info : frames_) {
    const std::string& pose = pose_paths[info.source_index];
    if (!pose.empty()) {
      info.T_w_c_gt = ReadPose(pose);
    } else if (without_pose++ == 0) {
      first_without_pose = std::filesystem::path(info.depth_path).filename().string();
    }
  }
  // As a TUM frame outside the ground truth's time span, a frame without a pose file has no
  // ground truth; when others have one, the gap is worth a line.
  if (without_pose > 0 && without_pose < size()) {
    warnings_.push_back(std::to_string(without_pose) + " of " + std::to_string(size()) +
                        " selected frames have no pose file (the first: " + first_without_pose +
                        "), so no ground truth");
  }
}

}  // namespace ieslam
