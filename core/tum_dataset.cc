#include "core/tum_dataset.h"

#include <filesystem>
#include <regex>

#include "core/calibration.h"
#include "core/file_util.h"
#include "core/listed_frames.h"

namespace ieslam {
namespace {

// The sequence's name: "rgbd_dataset_freiburg1_desk" for ".../rgbd_dataset_freiburg1_desk/"
// or for "." run inside it.
std::string DirectoryName(const std::string& directory) {
  std::error_code ec;
  std::filesystem::path path = std::filesystem::weakly_canonical(directory, ec);
  if (ec) path = std::filesystem::path(directory).lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  return path.filename().string();
}

}  // namespace

TumDataset::TumDataset(const std::string& directory, const DatasetOptions& options)
    : Dataset(directory, options) {
  const std::string local_calib = JoinPath(directory, "calib.yaml");
  std::error_code ec;
  if (!options.calib_file.empty()) {
    calibration_path_ = options.calib_file;
    calibration_source_ = "given calibration file";
    calibration_chosen_by_ = "option";
  } else if (std::filesystem::is_regular_file(local_calib, ec)) {
    // Datasets we write ourselves (ieslam synth) carry their rig with them.
    calibration_path_ = local_calib;
    calibration_source_ = "calib.yaml in the dataset directory";
    calibration_chosen_by_ = "dataset file";
  } else {
    // TUM sequences are named rgbd_dataset_freiburgN_...; fr1/fr2/fr3 are common short forms.
    static const std::regex kSequence(R"((freiburg|fr)_?([123])(?![0-9]))", std::regex::icase);
    const std::string name = DirectoryName(directory);
    std::smatch match;
    if (std::regex_search(name, match, kSequence)) {
      calibration_path_ = DefaultCalibrationPath("tum_fr" + match[2].str());
      calibration_source_ = "directory name '" + name + "' names freiburg" + match[2].str();
      calibration_chosen_by_ = "directory name";
    } else {
      // fr1's distortion and intrinsics on fr2/fr3 images run without error but measurably
      // worse, so the guess is a warning, not only a line of the report.
      calibration_path_ = DefaultCalibrationPath("tum_fr1");
      calibration_source_ = "default (directory name '" + name +
                            "' names no freiburg1/2/3 sequence; set a calibration file if the "
                            "camera is not freiburg1's)";
      calibration_chosen_by_ = "fallback";
      warnings_.push_back("the directory name '" + name +
                          "' names no TUM camera (freiburg1/2/3, fr1/2/3): using freiburg1's "
                          "calibration " +
                          calibration_path_ +
                          "; give a calibration file (--calib FILE) if the camera is another");
    }
  }
  rig_ = ReadCalibration(calibration_path_);
  SelectFrames(ReadListedFrames(JoinPath(directory, "rgb.txt"), JoinPath(directory, "depth.txt"),
                                JoinPath(directory, "groundtruth.txt"), options),
               options);
}

}  // namespace ieslam
