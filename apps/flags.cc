#include "apps/flags.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "core/error.h"

namespace ieslam {
namespace {

const FlagSpec* FindSpec(const std::vector<FlagSpec>& specs, const std::string& name) {
  for (const FlagSpec& spec : specs) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

}  // namespace

Flags::Flags(const std::vector<std::string>& args, const std::vector<FlagSpec>& specs) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      help_ = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) throw ConfigError("unexpected argument '" + arg + "'");
    std::string name = arg.substr(2), value;
    const size_t equals = name.find('=');
    const bool inline_value = equals != std::string::npos;
    if (inline_value) {
      value = name.substr(equals + 1);
      name = name.substr(0, equals);
    }
    const FlagSpec* spec = FindSpec(specs, name);
    if (spec == nullptr) throw ConfigError("unknown flag --" + name + " (see --help)");
    if (spec->value.empty()) {
      if (inline_value) throw ConfigError("flag --" + name + " takes no value");
      value = "1";
    } else if (!inline_value) {
      if (i + 1 >= args.size())
        throw ConfigError("flag --" + name + " needs a value " + spec->value);
      value = args[++i];
    }
    if (values_.count(name)) throw ConfigError("flag --" + name + " given twice");
    values_[name] = value;
  }
}

std::string Flags::GetString(const std::string& name, const std::string& fallback) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

std::string Flags::Require(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end() || it->second.empty()) {
    throw ConfigError("missing required flag --" + name + " (see --help)");
  }
  return it->second;
}

int Flags::GetInt(const std::string& name, int fallback, int min, int max) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end != '\0' || errno == ERANGE) {
    throw ConfigError("--" + name + " must be an integer, got '" + it->second + "'");
  }
  if (value < min || value > max) {
    throw ConfigError("--" + name + " must be in [" + std::to_string(min) + ", " +
                      std::to_string(max) + "], got " + it->second);
  }
  return static_cast<int>(value);
}

double Flags::GetDouble(const std::string& name, double fallback, double min, double max) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw ConfigError("--" + name + " must be a number, got '" + it->second + "'");
  }
  if (value < min || value > max) {
    std::ostringstream range;
    range << "--" << name << " must be in [" << min << ", " << max << "], got " << it->second;
    throw ConfigError(range.str());
  }
  return value;
}

std::vector<Flags> Flags::Items(const std::string& name) const {
  std::vector<Flags> items;
  std::stringstream list(values_.at(name));
  std::string item;
  while (std::getline(list, item, ','))
    items.emplace_back(Flags({"--" + name, item}, {{name, "N", ""}}));
  if (items.empty()) throw ConfigError("--" + name + " needs at least one value");
  return items;
}

std::vector<int> Flags::GetIntList(const std::string& name, const std::vector<int>& fallback,
                                   int min, int max) const {
  if (!Has(name)) return fallback;
  std::vector<int> list;
  for (const Flags& one : Items(name)) list.push_back(one.GetInt(name, 0, min, max));
  return list;
}

std::vector<double> Flags::GetDoubleList(const std::string& name,
                                         const std::vector<double>& fallback, size_t size,
                                         double min, double max) const {
  if (!Has(name)) return fallback;
  std::vector<double> list;
  for (const Flags& one : Items(name)) list.push_back(one.GetDouble(name, 0.0, min, max));
  if (list.size() != size) {
    throw ConfigError("--" + name + " needs " + std::to_string(size) +
                      " comma-separated values, got " + std::to_string(list.size()));
  }
  return list;
}

std::string FormatHelp(const std::string& command, const std::string& usage,
                       const std::string& description, const std::vector<FlagSpec>& specs) {
  std::ostringstream s;
  s << "Usage: ieslam " << command << " " << usage << "\n\n" << description << "\n\nFlags:\n";
  for (const FlagSpec& spec : specs) {
    std::string left = "  --" + spec.name + (spec.value.empty() ? "" : " " + spec.value);
    if (left.size() < 26) left.resize(26, ' ');
    s << left << " " << spec.help << "\n";
  }
  s << "  --help                   this text\n";
  return s.str();
}

}  // namespace ieslam
