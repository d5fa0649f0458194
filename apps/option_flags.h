// Command-line flags that set single registered options (`--buffer N` is selector.buffer):
// their help, placeholder and check come from the option's registration.
#pragma once

#include <string>
#include <vector>

#include <glog/logging.h>

#include "apps/flags.h"
#include "backend/evaluation/evaluation.h"
#include "core/option_registry.h"

namespace ieslam {

struct OptionFlag {
  std::string flag;    // without the dashes
  std::string option;  // "section.key", or "key" at the top level
};

// The flags' specs: a boolean option (0|1) is a flag without a value.
// The flags of `ieslam run` and of `ieslam evaluate` that set options, and the options
// `ieslam evaluate` reads: the Python module's keyword arguments set the same options.
const std::vector<OptionFlag>& RunOptionFlags();
// The flags of `ieslam localize` that set options (the Python module's localize keywords).
const std::vector<OptionFlag>& LocalizeOptionFlags();
const std::vector<OptionFlag>& EvaluateOptionFlags();
const OptionRegistry<EvaluationOptions>& EvaluationRegistry();

// The flags' specs: a boolean option (0|1) is a flag without a value.
template <typename R>
std::vector<FlagSpec> OptionFlagSpecs(const OptionRegistry<R>& registry,
                                      const std::vector<OptionFlag>& flags) {
  std::vector<FlagSpec> specs;
  const R defaults;
  for (const OptionFlag& f : flags) {
    const BoundOption<R>* option = registry.Find(f.option);
    CHECK(option != nullptr) << "no option " << f.option << " for --" << f.flag;
    std::string value = option->yaml(defaults);
    if (value.size() >= 2 && value.front() == '"') value = value.substr(1, value.size() - 2);
    const bool boolean = option->placeholder == "0|1";
    specs.push_back({f.flag, boolean ? "" : option->placeholder,
                     option->help + " (" + f.option + (boolean ? "" : ", default " + value) + ")"});
  }
  return specs;
}

// Sets the options of the flags given; ConfigError "--flag <reason>" for a bad value.
template <typename R>
void ApplyOptionFlags(const Flags& given, const OptionRegistry<R>& registry,
                      const std::vector<OptionFlag>& flags, R* root) {
  for (const OptionFlag& f : flags) {
    if (!given.Has(f.flag)) continue;
    const bool boolean = registry.Find(f.option)->placeholder == "0|1";
    registry.SetFromFlag(root, f.option, boolean ? "1" : given.GetString(f.flag), f.flag);
  }
}

}  // namespace ieslam
