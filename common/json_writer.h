// JSON output, the one home of its string escaping: JsonQuoted for files written by hand, JsonWriter (a minimal
// streaming writer: objects, arrays, strings, numbers, booleans; non-finite numbers as null) for summaries.
// Header-only, no dependencies.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace objscan {

// text as a JSON string literal: in quotes, with quotes and backslashes escaped and control characters as \n, \t,
// \r or \u00XX (bytes >= 0x80 pass unchanged: UTF-8 stays UTF-8).
inline std::string JsonQuoted(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

class JsonWriter {
 public:
  JsonWriter& BeginObject() { return Open('{'); }
  JsonWriter& EndObject() { return Close('}'); }
  JsonWriter& BeginArray() { return Open('['); }
  JsonWriter& EndArray() { return Close(']'); }
  JsonWriter& Key(const std::string& key) {
    Separator();
    AppendString(key);
    out_ += ": ";
    after_key_ = true;
    return *this;
  }
  JsonWriter& String(const std::string& value) {
    Separator();
    AppendString(value);
    return *this;
  }
  JsonWriter& Int(int64_t value) {
    Separator();
    out_ += std::to_string(value);
    return *this;
  }
  JsonWriter& Number(double value) {
    Separator();
    if (!std::isfinite(value)) {
      out_ += "null";
    } else {
      char buf[40];
      std::snprintf(buf, sizeof(buf), "%.6g", value);
      out_ += buf;
    }
    return *this;
  }
  JsonWriter& Bool(bool value) {
    Separator();
    out_ += value ? "true" : "false";
    return *this;
  }
  // A value that is already JSON text (e.g. a result file a process wrote), inserted as it is.
  JsonWriter& Raw(const std::string& json_value) {
    Separator();
    out_ += json_value;
    return *this;
  }
  const std::string& str() const { return out_; }

 private:
  JsonWriter& Open(char c) {
    Separator();
    out_ += c;
    first_.push_back(true);
    return *this;
  }
  JsonWriter& Close(char c) {
    first_.pop_back();
    out_ += '\n' + std::string(2 * first_.size(), ' ') + c;
    return *this;
  }
  void Separator() {
    if (after_key_) {
      after_key_ = false;
      return;
    }
    if (first_.empty()) return;
    if (!first_.back()) out_ += ',';
    first_.back() = false;
    out_ += '\n' + std::string(2 * first_.size(), ' ');
  }
  void AppendString(const std::string& s) { out_ += JsonQuoted(s); }
  std::string out_;
  std::vector<bool> first_;
  bool after_key_ = false;
};

}  // namespace objscan
