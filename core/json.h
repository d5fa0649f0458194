// A small JSON value for writing reports (report.json, evaluation.json, register.json):
// objects keep their keys in insertion order, doubles print in the shortest form that reads
// back to the same value (with ".0" when integral, so that they read back as doubles, unless
// made by BareDouble), NaN and inf print as null (JSON has no such numbers).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace ieslam {

class Json {
 public:
  Json() : kind_(Kind::kNull) {}
  Json(std::nullptr_t) : kind_(Kind::kNull) {}     // NOLINT(google-explicit-constructor)
  Json(bool b) : kind_(Kind::kBool), bool_(b) {}   // NOLINT(google-explicit-constructor)
  Json(int i) : kind_(Kind::kInt), int_(i) {}      // NOLINT(google-explicit-constructor)
  Json(int64_t i) : kind_(Kind::kInt), int_(i) {}  // NOLINT(google-explicit-constructor)
  Json(size_t i) : kind_(Kind::kInt), int_(static_cast<int64_t>(i)) {}  // NOLINT
  Json(double d) : kind_(Kind::kDouble), double_(d) {}       // NOLINT(google-explicit-constructor)
  Json(const char* s) : kind_(Kind::kString), string_(s) {}  // NOLINT
  Json(std::string s) : kind_(Kind::kString), string_(std::move(s)) {}  // NOLINT

  static Json Object();
  static Json Array();
  // A double printed without the ".0" an integral value otherwise gets (1, not 1.0), for a
  // file whose format prints its numbers so (evaluation.json).
  static Json BareDouble(double d);
  template <typename T>
  static Json ArrayOf(const std::vector<T>& values) {
    Json array = Array();
    for (const T& v : values) array.Push(Json(v));
    return array;
  }

  // Object: sets `key` (replacing an earlier value, keeping its position). Returns *this.
  Json& Set(const std::string& key, Json value);
  // Array: appends. Returns *this.
  Json& Push(Json value);
  // Object member access for building nested objects in place; creates the key if absent.
  Json& operator[](const std::string& key);

  bool is_object() const { return kind_ == Kind::kObject; }
  // An object without members or an array without items.
  bool empty() const { return members_.empty() && items_.empty(); }
  bool is_array() const { return kind_ == Kind::kArray; }

  // Pretty-printed with `indent` spaces (0: one line).
  std::string Dump(int indent = 2) const;

 private:
  enum class Kind { kNull, kBool, kInt, kDouble, kString, kObject, kArray };
  void DumpTo(std::string* out, int indent, int depth) const;

  Kind kind_;
  bool bool_ = false;
  int64_t int_ = 0;
  double double_ = 0.0;
  bool point_when_integral_ = true;  // a double: append ".0" to an integral value
  std::string string_;
  std::vector<std::pair<std::string, Json>> members_;  // object
  std::vector<Json> items_;                            // array
};

// JSON string literal with escapes, quotes included.
std::string JsonQuote(const std::string& s);

}  // namespace ieslam
