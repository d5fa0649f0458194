// What the Python module (apps/python/module.cc) converts between Python and the library:
// option values and dicts of them through a registry (core/option_registry.h), trajectories
// as N x 8 NumPy arrays in the TUM columns, images as arrays, and Json as Python objects.
#pragma once

#include <string>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/json.h"
#include "core/option_registry.h"
#include "core/trajectory.h"

namespace ieslam {

// A Python value as an option's text: a bool as 0|1 (as the CLI's switches), an int in
// decimal, a float as its repr (the shortest text that reads back the same), a str as a
// string (so that a number option refuses it as a YAML file's quoted value is refused).
// Throws ConfigError "<where>: <name> must be ..." for any other type.
OptionText OptionTextFromPython(const pybind11::handle& value, const std::string& name,
                                const std::string& where);

// Applies a dict of options: {"selector": {"buffer": 4}, "threads": 1}, sections as the
// registry names them (`ieslam options` prints them), top-level keys, or "section.key"
// names. Throws ConfigError naming `where` and the key for an unknown section or key, a value
// of the wrong type, or one failing its check (OptionRegistry::Set's messages).
template <typename R>
void ApplyOptionsDict(const OptionRegistry<R>& registry, const pybind11::dict& options,
                      const std::string& where, R* root) {
  for (const auto& item : options) {
    const std::string key = pybind11::str(item.first);
    if (!pybind11::isinstance<pybind11::dict>(item.second)) {
      registry.Set(root, key, OptionTextFromPython(item.second, key, where), where);
      continue;
    }
    bool known_section = false;
    for (const BoundOption<R>& o : registry.options()) known_section |= o.section == key;
    if (!known_section) throw ConfigError(where + ": unknown section '" + key + "'");
    for (const auto& inner : item.second.cast<pybind11::dict>()) {
      const std::string name = key + "." + std::string(pybind11::str(inner.first));
      registry.Set(root, name, OptionTextFromPython(inner.second, name, where), where);
    }
  }
}

// N x 8 float64, one row `t x y z qx qy qz qw` per pose, the quaternion's sign as in a TUM
// file (w >= 0).
pybind11::array_t<double> TrajectoryToArray(const Trajectory& trajectory);
// The inverse; the quaternion is normalised. Throws DataError naming `name` for an array that
// is not N x 8 or holds a zero or non-finite quaternion.
Trajectory ArrayToTrajectory(const pybind11::array_t<double>& array, const std::string& name);

// A CV_8UC3 BGR image as H x W x 3 uint8 RGB; a CV_32FC1 image as H x W float32. Copies.
pybind11::array_t<uint8_t> ColourToArray(const cv::Mat& bgr);
pybind11::array_t<float> DepthToArray(const cv::Mat& depth);

// The Python value of `json` (dicts, lists, floats, ints, strings, None).
pybind11::object JsonToPython(const Json& json);

}  // namespace ieslam
