// A rolling-shutter dataset's rig read as a global shutter, for tests that compare the two.
#pragma once

#include <filesystem>
#include <string>

#include "core/calibration.h"

namespace ieslam {
namespace testing_files {

// Writes `dataset`/calib.yaml without its readout time to `path` and returns `path` (as a
// string, for DatasetOptions::calib_file).
inline std::string WriteGlobalShutterCalibration(const std::filesystem::path& dataset,
                                                 const std::filesystem::path& path) {
  Rig rig = ReadCalibration((dataset / "calib.yaml").string());
  rig.colour_readout_s = 0.0;
  WriteCalibration(path.string(), rig);
  return path.string();
}

}  // namespace testing_files
}  // namespace ieslam
