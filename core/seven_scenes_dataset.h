// The Microsoft 7-Scenes format (Shotton et al., CVPR 2013): per frame
// frame-NNNNNN.color.{png,jpg}, frame-NNNNNN.depth.png (16-bit mm, 0 and 65535 invalid) and
// frame-NNNNNN.pose.txt (4x4 camera-to-world, row-major, of the depth camera, which with
// identity extrinsics is the colour camera's pose too). No timestamps: frame N is at N/30 s.
// A frame number with any of these files is a frame: one missing its colour or depth image is
// skipped when loaded (Load throws DataError), one missing its pose has no ground truth.
//
// Calibration: DatasetOptions::calib_file when set; else data/calib/7scenes.yaml with the
// depth intrinsics of the directory's camera-intrinsics.txt (a 3x3 K) when present.
#pragma once

#include <string>

#include "core/dataset.h"

namespace ieslam {

class SevenScenesDataset final : public Dataset {
 public:
  // Throws as OpenDataset (core/dataset.h); also DataError naming the file for a pose that
  // is not a finite rigid motion (read for the selected frames only).
  SevenScenesDataset(const std::string& directory, const DatasetOptions& options);
  std::string format() const override { return "7scenes"; }
};

}  // namespace ieslam
