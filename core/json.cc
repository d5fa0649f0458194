#include "core/json.h"

#include <charconv>
#include <cmath>
#include <cstdio>

#include <glog/logging.h>

namespace ieslam {

Json Json::Object() {
  Json json;
  json.kind_ = Kind::kObject;
  return json;
}

Json Json::Array() {
  Json json;
  json.kind_ = Kind::kArray;
  return json;
}

Json Json::BareDouble(double d) {
  Json json(d);
  json.point_when_integral_ = false;
  return json;
}

Json& Json::Set(const std::string& key, Json value) {
  (*this)[key] = std::move(value);
  return *this;
}

Json& Json::Push(Json value) {
  CHECK(kind_ == Kind::kArray) << "Push on a JSON value that is not an array";
  items_.push_back(std::move(value));
  return *this;
}

Json& Json::operator[](const std::string& key) {
  if (kind_ == Kind::kNull) kind_ = Kind::kObject;
  CHECK(kind_ == Kind::kObject) << "member '" << key << "' of a JSON value that is not an object";
  for (auto& member : members_) {
    if (member.first == key) return member.second;
  }
  members_.emplace_back(key, Json());
  return members_.back().second;
}

std::string JsonQuote(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
          out += buffer;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string Json::Dump(int indent) const {
  std::string out;
  DumpTo(&out, indent, 0);
  return out;
}

void Json::DumpTo(std::string* out, int indent, int depth) const {
  const auto newline = [&](int d) {
    if (indent > 0) *out += "\n" + std::string(static_cast<size_t>(indent * d), ' ');
  };
  switch (kind_) {
    case Kind::kNull:
      *out += "null";
      return;
    case Kind::kBool:
      *out += bool_ ? "true" : "false";
      return;
    case Kind::kInt:
      *out += std::to_string(int_);
      return;
    case Kind::kDouble: {
      if (!std::isfinite(double_)) {
        *out += "null";
        return;
      }
      char buffer[32];
      const auto result = std::to_chars(buffer, buffer + sizeof(buffer), double_);
      const std::string number(buffer, result.ptr);
      *out += number;
      // A double stays one when read back: "3" would come back as an integer in Python's
      // json, JavaScript's and most others'.
      if (point_when_integral_ && number.find_first_of(".e") == std::string::npos) *out += ".0";
      return;
    }
    case Kind::kString:
      *out += JsonQuote(string_);
      return;
    case Kind::kObject: {
      if (members_.empty()) {
        *out += "{}";
        return;
      }
      *out += "{";
      for (size_t i = 0; i < members_.size(); ++i) {
        if (i > 0) *out += ",";
        newline(depth + 1);
        *out += JsonQuote(members_[i].first) + (indent > 0 ? ": " : ":");
        members_[i].second.DumpTo(out, indent, depth + 1);
      }
      newline(depth);
      *out += "}";
      return;
    }
    case Kind::kArray: {
      if (items_.empty()) {
        *out += "[]";
        return;
      }
      // Arrays of scalars stay on one line; arrays of objects get a line per item.
      const bool nested =
          items_.front().kind_ == Kind::kObject || items_.front().kind_ == Kind::kArray;
      *out += "[";
      for (size_t i = 0; i < items_.size(); ++i) {
        if (i > 0) *out += nested || indent == 0 ? "," : ", ";
        if (nested) newline(depth + 1);
        items_[i].DumpTo(out, indent, depth + 1);
      }
      if (nested) newline(depth);
      *out += "]";
      return;
    }
  }
}

}  // namespace ieslam
