#include "core/yaml_text.h"

#include <cctype>
#include <stdexcept>

#include "core/error.h"

namespace ieslam {
namespace {

bool StartsWith(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

// Blank, or only spaces before a `#` comment (OpenCV skips spaces only, not tabs).
bool BlankOrComment(const std::string& s) {
  const size_t first = s.find_first_not_of(' ');
  return first == std::string::npos || s[first] == '#';
}

}  // namespace

// Why these rules: OpenCV 4.6's YAML parser (YAMLParser::parse) parses the root collection,
// and when that ends before the end of the text it skips three characters (taken to be `...`
// or `---`) and scans for the next document; standing on a `-` that does not start `---` it
// neither advances nor fails, so open() never returns.
// A block map whose first key is in column 1 ends only at the end of the text, at a `...`
// line or with a parse error; an indented root (one on the `---` line too) ends at the first
// line indented less, a flow root at its bracket (tests/core/yaml_text_test.cc holds one
// input per way in). Files are small, so the screen costs nothing worth counting.
std::string YamlForOpenCv(const std::string& text, const std::string& source) {
  const size_t nul = text.find('\0');
  if (nul != std::string::npos) {
    throw ConfigError(source + ": not a text file (NUL byte at offset " + std::to_string(nul) +
                      ")");
  }
  bool before_root = true;
  bool seen_start = false;  // the `---` line
  size_t begin = 0;
  for (int line_number = 1; begin < text.size(); ++line_number) {
    size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(begin, end - begin);
    begin = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string where = source + ":" + std::to_string(line_number) + ": ";
    if (StartsWith(line, "...")) {
      throw ConfigError(where + "'...' (end of document) is not supported: one document per file");
    }
    if (StartsWith(line, "---")) {
      if (!before_root || seen_start || !BlankOrComment(line.substr(3))) {
        throw ConfigError(where +
                          "'---' may only stand alone on a line before the first key: one "
                          "document per file");
      }
      seen_start = true;
      continue;
    }
    if (!before_root || BlankOrComment(line)) continue;
    if (line[0] == '%' && !seen_start) continue;  // a directive such as %YAML:1.0
    const unsigned char c = static_cast<unsigned char>(line[0]);
    if (!std::isalnum(c) && c != '_') {
      throw ConfigError(where + "expected a key in column 1 (the file is a map of keys), got '" +
                        line + "'");
    }
    before_root = false;
  }
  return StartsWith(text, "%YAML") ? text : "%YAML:1.0\n" + text;
}

cv::FileStorage OpenYamlMap(const std::string& text, const std::string& source) {
  const std::string yaml = YamlForOpenCv(text, source);
  cv::FileStorage fs;
  try {
    fs.open(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw ConfigError(source + ": not valid YAML: " + e.msg);
  } catch (const std::exception& e) {
    // Whatever else the parser throws is still a file we cannot read, not a program error.
    throw ConfigError(source + ": not valid YAML: " + e.what());
  }
  if (!fs.isOpened() || !fs.root().isMap()) {
    throw ConfigError(source + ": not valid YAML (expected a map of keys)");
  }
  return fs;
}

}  // namespace ieslam
