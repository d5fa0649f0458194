#include "core/yaml_text.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "core/error.h"

namespace ieslam {
namespace {

bool StartsWith(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// The nesting seen so far: the columns of the open block collections (a key or a `- ` entry
// opens one at its column) and the `[`/`{` not yet closed.
struct Nesting {
  std::vector<size_t> block_columns;
  int flow_depth = 0;

  void Block(size_t column, const std::string& where) {
    while (!block_columns.empty() && block_columns.back() >= column) block_columns.pop_back();
    block_columns.push_back(column);
    Check(where);
  }
  void Check(const std::string& where) const {
    if (static_cast<int>(block_columns.size()) + flow_depth > kMaxYamlNesting) {
      throw ConfigError(where + "nesting deeper than " + std::to_string(kMaxYamlNesting) +
                        " levels");
    }
  }
};

// Checks an integer scalar starting at line[i] (a sign or a digit at the start of a token)
// and returns the index past it; appends to `reals` the text offset after the digits of a
// decimal integer outside int's range (see YamlForOpenCv).
size_t ScreenInteger(const std::string& line, size_t i, size_t offset, const std::string& where,
                     std::vector<size_t>* reals) {
  const size_t digits = line[i] == '+' || line[i] == '-' ? i + 1 : i;
  size_t end = digits;
  while (end < line.size() && IsDigit(line[end])) ++end;
  // OpenCV reads a real when the digits run into `.` or `e`; a `:` ends a key.
  if (end < line.size() && (line[end] == '.' || line[end] == 'e' || line[end] == ':')) return end;
  errno = 0;
  char* stop = nullptr;
  const long long value = std::strtoll(line.c_str() + i, &stop, 0);  // as OpenCV's strtol
  const size_t stop_index = static_cast<size_t>(stop - line.c_str());
  if (errno != ERANGE && value >= std::numeric_limits<int>::min() &&
      value <= std::numeric_limits<int>::max()) {
    return std::max(stop_index, end);
  }
  if (line[digits] == '0' && stop_index > digits + 1) {
    throw ConfigError(where + "integer " + line.substr(i, stop_index - i) +
                      " is outside the range of int; write it in decimal");
  }
  reals->push_back(offset + end);
  return end;
}

// One line's nesting and integers outside quoted strings and comments. As in OpenCV, a
// `[`, `{`, quote or number means something only where a value starts: after `: `, after a
// line's `- ` entries, and inside a flow collection after `[`, `{` or `,`; elsewhere it is
// part of a plain string (`name: run [1` is one). `offset` is the line's position in the text.
void ScreenLine(const std::string& line, size_t offset, const std::string& where, Nesting* nesting,
                std::vector<size_t>* reals) {
  size_t i = line.find_first_not_of(' ');
  if (i == std::string::npos || line[i] == '#') return;
  if (nesting->flow_depth == 0) {  // else the line continues a flow collection
    nesting->Block(i, where);
    while (line[i] == '-' && (i + 1 == line.size() || line[i + 1] == ' ')) {
      i = line.find_first_not_of(' ', i + 1);
      if (i == std::string::npos) return;
      nesting->Block(i, where);
    }
  }
  char last = ':';  // the last character outside spaces; a line starts a key or a value
  while (i < line.size()) {
    const char c = line[i];
    if (c == ' ' || c == '\t') {
      ++i;
      continue;
    }
    if (c == '#' && i > 0 && (line[i - 1] == ' ' || line[i - 1] == '\t')) return;
    const bool value_start =
        last == ':' || (nesting->flow_depth > 0 && std::strchr("[{,", last) != nullptr);
    last = c;
    if (value_start && (c == '\'' || c == '"')) {
      size_t j = i + 1;
      while (j < line.size() && line[j] != c) j += c == '"' && line[j] == '\\' ? 2 : 1;
      i = j + 1;
      continue;
    }
    if (value_start && (c == '[' || c == '{')) {
      ++nesting->flow_depth;
      nesting->Check(where);
    } else if ((c == ']' || c == '}') && nesting->flow_depth > 0) {
      --nesting->flow_depth;
    } else if (value_start && (IsDigit(c) || ((c == '+' || c == '-') && i + 1 < line.size() &&
                                              IsDigit(line[i + 1])))) {
      i = ScreenInteger(line, i, offset, where, reals);
      last = line[i - 1];
      continue;
    }
    ++i;
  }
}

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
  if (text.size() > kMaxYamlBytes) {
    throw ConfigError(source + ": " + std::to_string(text.size()) + " bytes, more than the " +
                      std::to_string(kMaxYamlBytes) + " a YAML file may hold");
  }
  const size_t nul = text.find('\0');
  if (nul != std::string::npos) {
    throw ConfigError(source + ": not a text file (NUL byte at offset " + std::to_string(nul) +
                      ")");
  }
  bool before_root = true;
  bool seen_start = false;  // the `---` line
  Nesting nesting;
  std::vector<size_t> reals;
  size_t begin = 0;
  for (int line_number = 1; begin < text.size(); ++line_number) {
    size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const size_t offset = begin;
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
    if (line[0] == '%' && !seen_start) continue;  // a directive such as %YAML:1.0
    ScreenLine(line, offset, where, &nesting, &reals);
    if (!before_root || BlankOrComment(line)) continue;
    const unsigned char c = static_cast<unsigned char>(line[0]);
    if (!std::isalnum(c) && c != '_') {
      throw ConfigError(where + "expected a key in column 1 (the file is a map of keys), got '" +
                        line + "'");
    }
    before_root = false;
  }
  std::string screened = text;
  for (auto it = reals.rbegin(); it != reals.rend(); ++it) screened.insert(*it, 1, '.');
  return StartsWith(screened, "%YAML") ? screened : "%YAML:1.0\n" + screened;
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
