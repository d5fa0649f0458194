#include "core/option_table.h"

#include <cerrno>
#include <charconv>
#include <cstdlib>

namespace ieslam {

int64_t ParseOptionInteger(const OptionText& value, int64_t min, int64_t max) {
  const std::string& text = value.text;
  if (value.is_string) throw ConfigError("must be an integer, got the string '" + text + "'");
  int64_t parsed = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), parsed);
  if (text.empty() || end != text.data() + text.size() || ec == std::errc::invalid_argument) {
    throw ConfigError("must be an integer, got '" + text + "'");
  }
  if (ec == std::errc::result_out_of_range || parsed < min || parsed > max) {
    throw ConfigError("must be in [" + std::to_string(min) + ", " + std::to_string(max) +
                      "], got " + text);
  }
  return parsed;
}

double ParseOptionReal(const OptionText& value) {
  const std::string& text = value.text;
  if (value.is_string) throw ConfigError("must be a number, got the string '" + text + "'");
  char* end = nullptr;
  errno = 0;
  const double parsed = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') throw ConfigError("must be a number, got '" + text + "'");
  if (!std::isfinite(parsed) || errno == ERANGE) {
    throw ConfigError("must be finite, got " + text);
  }
  return parsed;
}

std::string FormatOptionReal(double value) {
  if (!std::isfinite(value)) return std::isnan(value) ? ".nan" : (value > 0 ? ".inf" : "-.inf");
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  std::string text(buffer, result.ptr);
  if (text.find_first_of(".e") == std::string::npos) text += ".0";
  return text;
}

}  // namespace ieslam
