// The TUM RGB-D format (Sturm et al., IROS 2012): rgb.txt and depth.txt list `timestamp
// path`, groundtruth.txt (optional) holds the colour camera's motion-capture poses. Depth is
// registered to colour, 16-bit, raw / 5000 = metres. Colour and depth are associated by
// timestamp as TUM's associate.py does (core/timestamp_association.h).
//
// Calibration: DatasetOptions::calib_file when set; else calib.yaml in the directory if
// present; else data/calib/tum_fr{1,2,3}.yaml by the directory name (freiburg1/fr1, ...;
// tum_fr1 when the name says nothing, with a warning in warnings()).
#pragma once

#include <string>

#include "core/dataset.h"

namespace ieslam {

class TumDataset final : public Dataset {
 public:
  // Throws as OpenDataset (core/dataset.h).
  TumDataset(const std::string& directory, const DatasetOptions& options);
  std::string format() const override { return "tum"; }
};

}  // namespace ieslam
