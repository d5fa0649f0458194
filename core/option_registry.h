// The options of a command as sections of option tables (core/option_table.h) bound to one
// root struct: `features` is the FeatureOptions table at root.source.frontend.features, and
// so on. One registry gives the command its `--config` reader, the "options" of its report,
// the text of its default config file and the flags that set single options.
//
// A section is named in YAML and JSON by its name; the section named "" holds options at the
// top level (`threads: 0`). A section may bind several tables (depth_alignment holds the
// alignment's options and the range clouds' grid step).
#pragma once

#include <algorithm>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/json.h"
#include "core/option_table.h"

namespace ieslam {

// One option of a registry, bound to the root struct R.
template <typename R>
struct BoundOption {
  std::string section;
  std::string key;
  std::string help;
  std::string placeholder;
  bool settable = true;
  std::function<void(const OptionText&, R*)> set;
  std::function<Json(const R&)> json;
  std::function<std::string(const R&)> yaml;
  std::function<std::string(const R&)> check;  // "" or the reason

  // "section.key", or "key" at the top level.
  std::string name() const { return section.empty() ? key : section + "." + key; }
};

// The config file's options: (section, key, value) in file order; the section is "" for a
// top-level scalar. Throws ConfigError naming the file when it is missing, not a regular
// file, not readable, or not a YAML map of maps and scalars.
struct YamlOption {
  std::string section;
  std::string key;
  OptionText value;
};
std::vector<YamlOption> ReadYamlOptions(const std::string& path);
// The same for a config file's text; `source` names it in errors.
std::vector<YamlOption> ParseYamlOptions(const std::string& text, const std::string& source);

// The YAML text of sections of `key: value  # help` lines.
struct YamlLine {
  std::string section;
  std::string key;
  std::string value;
  std::string help;
};
std::string FormatYamlOptions(const std::vector<YamlLine>& lines, const std::string& header);

template <typename R>
class OptionRegistry {
 public:
  // Binds table `table` of the struct at `access(root)` under `section`.
  template <typename S>
  OptionRegistry& Section(const std::string& section, const OptionTable<S>& table,
                          std::function<S*(R*)> access) {
    for (const OptionEntry<S>& e : table.entries()) {
      BoundOption<R> b;
      b.section = section;
      b.key = e.key;
      b.help = e.help;
      b.placeholder = e.placeholder;
      b.settable = e.settable;
      const auto cref = [access](const R& root) -> const S& {
        return *access(const_cast<R*>(&root));
      };
      b.set = [access, set = e.set](const OptionText& v, R* root) { set(v, access(root)); };
      b.json = [cref, json = e.json](const R& root) { return json(cref(root)); };
      b.yaml = [cref, yaml = e.yaml](const R& root) { return yaml(cref(root)); };
      b.check = [cref, entry = &e](const R& root) { return entry->Check(cref(root)); };
      options_.push_back(std::move(b));
    }
    for (const auto& check : table.cross_checks()) {
      cross_.push_back([access, check, section](const R& root) {
        const std::string reason = check(*access(const_cast<R*>(&root)));
        return reason.empty() || section.empty() ? reason : section + ": " + reason;
      });
    }
    return *this;
  }

  // Every option's check ("section.key must be ..."), then the tables' cross checks.
  bool Check(const R& root, std::string* why) const {
    std::string reason;
    for (const BoundOption<R>& o : options_) {
      reason = o.check(root);
      if (!reason.empty()) {
        reason = o.name() + " " + reason;
        break;
      }
    }
    for (size_t i = 0; i < cross_.size() && reason.empty(); ++i) reason = cross_[i](root);
    if (!reason.empty() && why != nullptr) *why = reason;
    return reason.empty();
  }

  const std::vector<BoundOption<R>>& options() const { return options_; }
  const BoundOption<R>* Find(const std::string& name) const {
    for (const BoundOption<R>& o : options_) {
      if (o.name() == name) return &o;
    }
    return nullptr;
  }

  // Sets option `name` ("section.key") from `value`; `where` prefixes messages (a file, a
  // flag). Throws ConfigError "<where>: <name> <reason>" for an unknown or derived option, a
  // value of the wrong type, or one failing its check.
  void Set(R* root, const std::string& name, const OptionText& value,
           const std::string& where) const {
    const BoundOption<R>* option = Find(name);
    if (option == nullptr) throw ConfigError(where + ": " + name + " is not a known option");
    if (!option->settable) {
      throw ConfigError(where + ": " + name +
                        " is not set directly (see its help: " + option->help + ")");
    }
    try {
      option->set(value, root);
    } catch (const ConfigError& e) {
      throw ConfigError(where + ": " + name + " " + e.what());
    }
    const std::string reason = option->check(*root);
    if (!reason.empty()) throw ConfigError(where + ": " + name + " " + reason);
  }

  // Sets option `name` from the value of command-line flag `flag`: ConfigError
  // "--<flag> <reason>" as the flags' own errors read.
  void SetFromFlag(R* root, const std::string& name, const std::string& value,
                   const std::string& flag) const {
    const BoundOption<R>* option = Find(name);
    if (option == nullptr) throw ConfigError("--" + flag + ": no option " + name);
    try {
      option->set({value, false}, root);
    } catch (const ConfigError& e) {
      throw ConfigError("--" + flag + " " + e.what());
    }
    const std::string reason = option->check(*root);
    if (!reason.empty()) throw ConfigError("--" + flag + " " + reason);
  }

  // Every option the file sets (ReadYamlOptions). An unknown section names the section.
  void ApplyYaml(const std::string& path, R* root) const {
    ApplyOptions(ReadYamlOptions(path), path, root);
  }
  // Options read by ReadYamlOptions or ParseYamlOptions; `path` names their source in errors.
  void ApplyOptions(const std::vector<YamlOption>& yaml, const std::string& path, R* root) const {
    for (const YamlOption& o : yaml) {
      const bool known_section = o.section.empty() || std::any_of(options_.begin(), options_.end(),
                                                                  [&o](const BoundOption<R>& b) {
                                                                    return b.section == o.section;
                                                                  });
      if (!known_section) throw ConfigError(path + ": unknown section '" + o.section + "'");
      Set(root, o.section.empty() ? o.key : o.section + "." + o.key, o.value, path);
    }
  }

  // {section: {key: value}} and top-level keys, in registration order.
  Json ToJson(const R& root) const {
    Json json = Json::Object();
    for (const BoundOption<R>& o : options_) {
      if (o.section.empty()) {
        json.Set(o.key, o.json(root));
      } else {
        json[o.section].Set(o.key, o.json(root));
      }
    }
    return json;
  }

  // The config file of `root`'s settable options, with their help as comments.
  std::string ToYaml(const R& root, const std::string& header) const {
    std::vector<YamlLine> lines;
    for (const BoundOption<R>& o : options_) {
      if (o.settable) lines.push_back({o.section, o.key, o.yaml(root), o.help});
    }
    return FormatYamlOptions(lines, header);
  }

 private:
  std::vector<BoundOption<R>> options_;
  std::vector<std::function<std::string(const R&)>> cross_;
};

}  // namespace ieslam
