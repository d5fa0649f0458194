#include "core/pair_dataset.h"

#include <filesystem>

#include "core/calibration.h"
#include "core/file_util.h"
#include "core/listed_frames.h"

namespace ieslam {

PairDataset::PairDataset(const std::string& directory, const DatasetOptions& options)
    : Dataset(directory, options) {
  if (options.calib_file.empty()) {
    calibration_path_ = JoinPath(directory, "calib.yaml");
    calibration_source_ = "calib.yaml in the dataset directory";
    calibration_chosen_by_ = "dataset file";
    RequireFile(calibration_path_, "pair dataset calibration");
  } else {
    calibration_path_ = options.calib_file;
    calibration_source_ = "given calibration file";
    calibration_chosen_by_ = "option";
  }
  rig_ = ReadCalibration(calibration_path_);
  SelectFrames(ReadListedFrames(JoinPath(directory, "colour.txt"), JoinPath(directory, "range.txt"),
                                JoinPath(directory, "groundtruth.txt"), options),
               options);
}

}  // namespace ieslam
