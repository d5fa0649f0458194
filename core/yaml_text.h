// The one door through which user YAML files (calibration, `--config`) reach OpenCV's
// parser, cv::FileStorage. OpenCV 4.6 loops forever on some texts (see yaml_text.cc), and
// throws std::length_error on texts with NUL bytes; the files ieslam reads are one YAML
// document whose root map starts in column 1, so anything else is refused before OpenCV
// sees it, with a message naming the file and the line.
#pragma once

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace ieslam {

// The calibrations and configs ieslam reads are under 10 KB; 4 MiB leaves room for any
// hand-written file while a runaway input is refused before it is read or parsed.
constexpr std::uintmax_t kMaxYamlBytes = std::uintmax_t{4} << 20;
// The files nest three levels deep; OpenCV's parser recurses once per level and overflows
// the stack (a segfault, no message) at tens of thousands, so 64 is generous and safe.
constexpr int kMaxYamlNesting = 64;

// `text` as cv::FileStorage reads it from memory: the `%YAML:1.0` directive OpenCV wants is
// prepended when missing (hand-written files often lack it). Throws ConfigError
// "<source>:<line>: ..." for a NUL byte, a top-level key not in column 1 (or a root that is
// not a block map), a second `---`, or text on the `---` line, for a `...` end marker, for
// nesting (block indentation levels plus open `[`/`{`) deeper than kMaxYamlNesting, and for
// a hexadecimal or octal integer outside int's range; a text longer than kMaxYamlBytes is
// refused too. OpenCV reads an integer through a cast of strtol to int, wrapping
// 4294967306 to 10, so a decimal integer outside int's range is handed to it as a real
// (a `.` appended), which keeps its value for the reader's own range check.
std::string YamlForOpenCv(const std::string& text, const std::string& source);

// cv::FileStorage opened on YamlForOpenCv(text); throws ConfigError naming `source` when
// OpenCV cannot parse it or its root is not a map.
cv::FileStorage OpenYamlMap(const std::string& text, const std::string& source);

}  // namespace ieslam
