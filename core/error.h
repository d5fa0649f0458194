// Errors the library raises for bad input. Programmer errors are CHECKs (glog);
// these are for data and configuration a user hands us, and their messages name
// the file, the frame and the value so that the user can act on them.
#pragma once

#include <stdexcept>
#include <string>

namespace ieslam {

// Bad input data: a missing or corrupt file, an inconsistent sequence.
// The CLI maps it to exit code 3.
class DataError : public std::runtime_error {
 public:
  explicit DataError(const std::string& what) : std::runtime_error(what) {}
};

// A bad option or configuration value. The CLI maps it to exit code 2.
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& what) : std::runtime_error(what) {}
};

// An output that cannot be written: the output directory not creatable or not writable, a
// full disk. The CLI maps it to exit code 4 (the input was fine).
class OutputError : public std::runtime_error {
 public:
  explicit OutputError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace ieslam
