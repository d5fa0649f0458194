// `--config FILE`: a YAML file (OpenCV FileStorage syntax) holding the Options of every stage,
// section by section, e.g.
//
//   %YAML:1.0
//   features: { max_features: 1000, image_scale: 0.5 }
//   selector: { kind: "info", buffer: 3 }
//
// Top-level keys start in column 1 (core/yaml_text.h). Every key is optional; an unknown
// section or key, a value of the wrong type or a NaN is a ConfigError naming the file and the
// key. Flags given on the command line override the file.
// data/config/default.yaml lists every key with its default.
#pragma once

#include <string>

#include "selection/pipeline/dataset_run.h"

namespace ieslam {

void ApplyConfigFile(const std::string& path, RunOptions* options);

}  // namespace ieslam
