// Command-line flags of one subcommand: `--name value` and boolean `--name`.
// Unknown flags, missing values and unparsable or out-of-range numbers are ConfigErrors
// (exit code 2) whose message names the flag and the value.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace ieslam {

struct FlagSpec {
  std::string name;   // without the leading dashes
  std::string value;  // placeholder shown in help ("DIR", "N"); empty for a boolean flag
  std::string help;
};

class Flags {
 public:
  // Parses args (everything after the subcommand). `--help` is always accepted.
  Flags(const std::vector<std::string>& args, const std::vector<FlagSpec>& specs);

  bool help() const { return help_; }
  bool Has(const std::string& name) const { return values_.count(name) > 0; }
  std::string GetString(const std::string& name, const std::string& fallback = "") const;
  // Throws ConfigError unless the flag was given.
  std::string Require(const std::string& name) const;
  int GetInt(const std::string& name, int fallback, int min, int max) const;
  // A finite number in [min, max].
  double GetDouble(const std::string& name, double fallback, double min, double max) const;
  // Comma-separated integers, e.g. --buffers 2,3,4,5.
  std::vector<int> GetIntList(const std::string& name, const std::vector<int>& fallback, int min,
                              int max) const;
  // Exactly `size` comma-separated finite numbers in [min, max], e.g. --depth-correction
  // -0.02,0.003,0.004.
  std::vector<double> GetDoubleList(const std::string& name, const std::vector<double>& fallback,
                                    size_t size, double min, double max) const;

 private:
  // The comma-separated items of flag `name` (given), each as a flag of its own.
  std::vector<Flags> Items(const std::string& name) const;

  std::map<std::string, std::string> values_;
  bool help_ = false;
};

// "Usage: ieslam <command> <usage>" followed by one line per flag.
std::string FormatHelp(const std::string& command, const std::string& usage,
                       const std::string& description, const std::vector<FlagSpec>& specs);

}  // namespace ieslam
