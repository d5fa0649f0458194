#include "core/option_registry.h"

#include <sstream>

#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/input_file.h"
#include "core/yaml_text.h"

namespace ieslam {
namespace {

// A scalar node's value as text; ConfigError naming `name` for anything else.
OptionText ScalarText(const cv::FileNode& node, const std::string& name) {
  if (node.isString()) return {static_cast<std::string>(node), true};
  if (node.isInt()) return {std::to_string(static_cast<int>(node)), false};
  if (node.isReal()) {
    std::ostringstream text;
    text.precision(17);
    text << static_cast<double>(node);
    return {text.str(), false};
  }
  throw ConfigError(name + " must be a number or a string");
}

std::string ReadConfigText(const std::string& path) {
  // A config file that is not there, not a regular file or not readable is bad usage
  // (exit 2), as a bad value in it is.
  try {
    return ReadInputFile(path, "config file", kMaxYamlBytes);
  } catch (const DataError& e) {
    throw ConfigError(e.what());
  }
}

}  // namespace

std::vector<YamlOption> ReadYamlOptions(const std::string& path) {
  return ParseYamlOptions(ReadConfigText(path), path);
}

std::vector<YamlOption> ParseYamlOptions(const std::string& text, const std::string& path) {
  const cv::FileStorage fs = OpenYamlMap(text, path);
  std::vector<YamlOption> options;
  for (const cv::FileNode& node : fs.root()) {
    const std::string name = node.name();
    if (!node.isMap()) {
      options.push_back({"", name, ScalarText(node, path + ": " + name)});
      continue;
    }
    for (const cv::FileNode& child : node) {
      const std::string key = child.name();
      options.push_back({name, key, ScalarText(child, path + ": " + name + "." + key)});
    }
  }
  return options;
}

std::string FormatYamlOptions(const std::vector<YamlLine>& lines, const std::string& header) {
  constexpr size_t kCommentColumn = 28;
  std::string text = "%YAML:1.0\n---\n" + header;
  std::string section = "\x01";  // none yet
  for (const YamlLine& line : lines) {
    if (line.section != section) {
      section = line.section;
      if (!section.empty()) text += section + ":\n";
    }
    std::string entry = (section.empty() ? "" : "  ") + line.key + ": " + line.value;
    if (!line.help.empty()) {
      if (entry.size() + 1 < kCommentColumn)
        entry.resize(kCommentColumn, ' ');
      else
        entry += "  ";
      entry += "# " + line.help;
    }
    text += entry + "\n";
  }
  return text;
}

}  // namespace ieslam
