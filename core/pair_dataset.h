// The "pair" format: a colour camera and a separate range imager, each at its own
// resolution and rate, as in the paper's Dragonfly2 + SwissRanger package.
//
//   DIR/calib.yaml       the rig, in core/calibration.h's format (two cameras, extrinsics);
//                        required unless DatasetOptions::calib_file is given
//   DIR/colour.txt       `timestamp path` per line (TUM style; `#` comments, blank lines),
//                        colour images any OpenCV-readable format, colour.width x height
//   DIR/range.txt        `timestamp path` per line, 16-bit single-channel PNG range images,
//                        range.width x height, raw * depth_scale = metres (z or radial as
//                        depth_kind says), raw values in invalid_values = no measurement
//   DIR/groundtruth.txt  optional: TUM trajectory `t tx ty tz qx qy qz qw` of the colour
//                        camera (T_w_c)
//
// Paths in the lists are relative to DIR (or absolute). Timestamps strictly increase within a
// list; colour and range images are associated by nearest timestamp within
// DatasetOptions::max_association_diff_s (TUM's associate.py rule), so a range imager
// triggered with the camera may carry the very same timestamps.
#pragma once

#include <string>

#include "core/dataset.h"

namespace ieslam {

class PairDataset final : public Dataset {
 public:
  // Throws as OpenDataset (core/dataset.h).
  PairDataset(const std::string& directory, const DatasetOptions& options);
  std::string format() const override { return "pair"; }
};

}  // namespace ieslam
