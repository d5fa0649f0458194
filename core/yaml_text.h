// The one door through which user YAML files (calibration, `--config`) reach OpenCV's
// parser, cv::FileStorage. OpenCV 4.6 loops forever on some texts (see yaml_text.cc), and
// throws std::length_error on texts with NUL bytes; the files ieslam reads are one YAML
// document whose root map starts in column 1, so anything else is refused before OpenCV
// sees it, with a message naming the file and the line.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace ieslam {

// `text` as cv::FileStorage reads it from memory: the `%YAML:1.0` directive OpenCV wants is
// prepended when missing (hand-written files often lack it). Throws ConfigError
// "<source>:<line>: ..." for a NUL byte, a top-level key not in column 1 (or a root that is
// not a block map), a second `---`, or text on the `---` line, and for a `...` end marker.
std::string YamlForOpenCv(const std::string& text, const std::string& source);

// cv::FileStorage opened on YamlForOpenCv(text); throws ConfigError naming `source` when
// OpenCV cannot parse it or its root is not a map.
cv::FileStorage OpenYamlMap(const std::string& text, const std::string& source);

}  // namespace ieslam
