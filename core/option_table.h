// The one registration of an Options struct's options: for each, its key, the member that
// holds it, its help and the check of its value (the member's default initialiser is its
// default). From a table come the struct's Check(), the options' JSON in reports, the YAML
// of `--config` files (read and written) and the command-line flags that set them
// (core/option_registry.h binds tables to the sections of a command's options).
//
//   const OptionTable<SelectorOptions>& SelectorOptions::Table() {
//     static const auto* table = [] {
//       auto* t = new OptionTable<SelectorOptions>;
//       t->Int("buffer", &SelectorOptions::buffer_size, "look-ahead buffer").Range(1, 100);
//       return t;
//     }();
//     return *table;
//   }
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "core/error.h"
#include "core/json.h"

namespace ieslam {

// A value given for an option: its text, and whether it came as a string (quoted in YAML);
// flag values are text to be parsed whatever their option's type.
struct OptionText {
  std::string text;
  bool is_string = false;
};

// Text parsing and formatting shared by the tables; each throws ConfigError with a reason
// ("must be an integer, got 'x'") that the caller prefixes with where the value came from.
int64_t ParseOptionInteger(const OptionText& value, int64_t min, int64_t max);
double ParseOptionReal(const OptionText& value);
// YAML and help text of a double: the shortest that reads back the same, with ".0" when
// integral, so that it reads back as a real.
std::string FormatOptionReal(double value);

// One option of an Options struct T, type-erased over the member's type.
template <typename T>
struct OptionEntry {
  std::string key;
  std::string help;
  std::string placeholder;  // for help texts: N, X, 0|1, the enum's names
  bool settable = true;     // false: reported, but set from another option (a run's seed)
  std::function<void(const OptionText&, T*)> set;  // throws ConfigError(reason)
  std::function<Json(const T&)> json;
  std::function<std::string(const T&)> yaml;  // the value as YAML text
  // The checks on the value; each returns "" or the reason it fails ("must be ...").
  std::vector<std::function<std::string(const T&)>> checks;

  std::string Check(const T& options) const {
    for (const auto& check : checks) {
      const std::string reason = check(options);
      if (!reason.empty()) return reason;
    }
    return "";
  }
};

// The checks a registration adds to its option, by the option's value type.
template <typename T, typename V>
class OptionBuilder {
 public:
  OptionBuilder(OptionEntry<T>* entry, V T::*member) : entry_(entry), member_(member) {}

  // Inclusive bounds.
  OptionBuilder& Range(V min, V max) {
    return Require([min, max](V v) { return v >= min && v <= max; },
                   "in [" + Text(min) + ", " + Text(max) + "]");
  }
  OptionBuilder& Min(V min) {
    return Require([min](V v) { return v >= min; }, ">= " + Text(min));
  }
  OptionBuilder& Max(V max) {
    return Require([max](V v) { return v <= max; }, "<= " + Text(max));
  }
  // Exclusive bounds.
  OptionBuilder& Above(V bound) {
    return Require([bound](V v) { return v > bound; }, "> " + Text(bound));
  }
  OptionBuilder& Below(V bound) {
    return Require([bound](V v) { return v < bound; }, "< " + Text(bound));
  }
  // `holds(value)` must be true; otherwise the reason is "must be <what>, got <value>".
  OptionBuilder& Require(std::function<bool(V)> holds, const std::string& what) {
    const auto member = member_;
    entry_->checks.push_back([member, holds, what](const T& options) {
      const V& value = options.*member;
      return holds(value) ? std::string() : "must be " + what + ", got " + Text(value);
    });
    return *this;
  }
  // Reported, but set by another option.
  OptionBuilder& Derived() {
    entry_->settable = false;
    return *this;
  }

 private:
  static std::string Text(V value) {
    if constexpr (std::is_floating_point_v<V>) {
      return FormatOptionReal(value);
    } else {
      return std::to_string(value);
    }
  }

  OptionEntry<T>* entry_;
  V T::*member_;
};

template <typename T>
class OptionTable {
 public:
  OptionBuilder<T, int> Int(const std::string& key, int T::*member, const std::string& help) {
    OptionEntry<T>& e = Add(key, help, "N");
    e.set = [member](const OptionText& v, T* o) {
      o->*member = static_cast<int>(
          ParseOptionInteger(v, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
    };
    e.json = [member](const T& o) { return Json(o.*member); };
    e.yaml = [member](const T& o) { return std::to_string(o.*member); };
    return OptionBuilder<T, int>(&e, member);
  }
  OptionBuilder<T, uint32_t> Uint(const std::string& key, uint32_t T::*member,
                                  const std::string& help) {
    OptionEntry<T>& e = Add(key, help, "N");
    e.set = [member](const OptionText& v, T* o) {
      o->*member =
          static_cast<uint32_t>(ParseOptionInteger(v, 0, std::numeric_limits<uint32_t>::max()));
    };
    e.json = [member](const T& o) { return Json(static_cast<int64_t>(o.*member)); };
    e.yaml = [member](const T& o) { return std::to_string(o.*member); };
    return OptionBuilder<T, uint32_t>(&e, member);
  }
  // Finite always.
  OptionBuilder<T, double> Double(const std::string& key, double T::*member,
                                  const std::string& help) {
    OptionEntry<T>& e = Add(key, help, "X");
    e.set = [member](const OptionText& v, T* o) { o->*member = ParseOptionReal(v); };
    e.json = [member](const T& o) { return Json(o.*member); };
    e.yaml = [member](const T& o) { return FormatOptionReal(o.*member); };
    OptionBuilder<T, double> builder(&e, member);
    builder.Require([](double v) { return std::isfinite(v); }, "finite");
    return builder;
  }
  // 0 or 1 in YAML and flags, true or false in JSON.
  void Bool(const std::string& key, bool T::*member, const std::string& help) {
    OptionEntry<T>& e = Add(key, help, "0|1");
    e.set = [member](const OptionText& v, T* o) { o->*member = ParseOptionInteger(v, 0, 1) == 1; };
    e.json = [member](const T& o) { return Json(o.*member); };
    e.yaml = [member](const T& o) { return std::string(o.*member ? "1" : "0"); };
  }
  void String(const std::string& key, std::string T::*member, const std::string& help,
              const std::string& placeholder = "TEXT") {
    OptionEntry<T>& e = Add(key, help, placeholder);
    e.set = [member](const OptionText& v, T* o) { o->*member = v.text; };
    e.json = [member](const T& o) { return Json(o.*member); };
    e.yaml = [member](const T& o) { return JsonQuote(o.*member); };
  }
  // A string that must be one of `choices`.
  void Choice(const std::string& key, std::string T::*member,
              const std::vector<std::string>& choices, const std::string& help) {
    std::string names;
    for (const std::string& c : choices) names += (names.empty() ? "" : "|") + c;
    OptionEntry<T>& e = Add(key, help, names);
    e.set = [member, choices, names](const OptionText& v, T* o) {
      if (std::find(choices.begin(), choices.end(), v.text) == choices.end()) {
        throw ConfigError("must be one of " + names + ", got '" + v.text + "'");
      }
      o->*member = v.text;
    };
    e.json = [member](const T& o) { return Json(o.*member); };
    e.yaml = [member](const T& o) { return JsonQuote(o.*member); };
    e.checks.push_back([member, choices, names](const T& o) {
      return std::find(choices.begin(), choices.end(), o.*member) != choices.end()
                 ? std::string()
                 : "must be one of " + names + ", got '" + o.*member + "'";
    });
  }
  // An enum by its names: `parse` as ParseSelectorKind, `name` as SelectorKindName;
  // `names` lists them for help and messages ("info|all|interval").
  template <typename E>
  void Enum(const std::string& key, E T::*member, bool (*parse)(const std::string&, E*),
            std::string (*name)(E), const std::string& names, const std::string& help) {
    OptionEntry<T>& e = Add(key, help, names);
    e.set = [member, parse, names](const OptionText& v, T* o) {
      if (!parse(v.text, &(o->*member))) {
        throw ConfigError("must be one of " + names + ", got '" + v.text + "'");
      }
    };
    e.json = [member, name](const T& o) { return Json(name(o.*member)); };
    e.yaml = [member, name](const T& o) { return JsonQuote(name(o.*member)); };
  }
  // A check across options (final_gate_m <= initial_gate_m); `check` returns "" or the reason.
  void Require(std::function<std::string(const T&)> check) { cross_.push_back(std::move(check)); }

  const std::deque<OptionEntry<T>>& entries() const { return entries_; }
  const std::vector<std::function<std::string(const T&)>>& cross_checks() const { return cross_; }
  const OptionEntry<T>* Find(const std::string& key) const {
    for (const OptionEntry<T>& e : entries_) {
      if (e.key == key) return &e;
    }
    return nullptr;
  }

  // Every option's check, then the cross checks; the first reason that fails, as
  // "<key> <reason>", into *why.
  bool Check(const T& options, std::string* why) const {
    for (const OptionEntry<T>& e : entries_) {
      const std::string reason = e.Check(options);
      if (!reason.empty()) return Fail(why, e.key + " " + reason);
    }
    for (const auto& check : cross_) {
      const std::string reason = check(options);
      if (!reason.empty()) return Fail(why, reason);
    }
    return true;
  }
  // The options as a JSON object, in registration order.
  Json ToJson(const T& options) const {
    Json json = Json::Object();
    for (const OptionEntry<T>& e : entries_) json.Set(e.key, e.json(options));
    return json;
  }

 private:
  OptionEntry<T>& Add(const std::string& key, const std::string& help,
                      const std::string& placeholder) {
    entries_.push_back(OptionEntry<T>());
    entries_.back().key = key;
    entries_.back().help = help;
    entries_.back().placeholder = placeholder;
    return entries_.back();
  }
  static bool Fail(std::string* why, const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  }

  // A deque: the builder of an entry keeps pointing at it while later ones are added.
  std::deque<OptionEntry<T>> entries_;
  std::vector<std::function<std::string(const T&)>> cross_;
};

}  // namespace ieslam
