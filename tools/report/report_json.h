// A small JSON value for the tools' reports (report.json, `ffseg eval --json`)
// and a strict parser to read them back (tests). Objects keep insertion order.
// Non-finite numbers are written as null (JSON has no infinity or NaN).
#ifndef FFSEG_TOOLS_REPORT_JSON_H
#define FFSEG_TOOLS_REPORT_JSON_H

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace ffseg_tools {

class Json {
 public:
  enum class Type { Null, Bool, Number, String, Array, Object };

  Json() = default;  // null
  Json(bool b) : type_(Type::Bool), b_(b) {}
  Json(double v) : type_(Type::Number), num_(v) {}
  Json(int v) : type_(Type::Number), num_(v), integral_(true), i_(v) {}
  Json(int64_t v) : type_(Type::Number), num_(double(v)), integral_(true), i_(v) {}
  Json(uint32_t v) : Json(int64_t(v)) {}
  Json(uint64_t v) : Json(int64_t(v)) {}
  Json(const char* s) : type_(Type::String), str_(s) {}
  Json(std::string s) : type_(Type::String), str_(std::move(s)) {}
  static Json array() { Json j; j.type_ = Type::Array; return j; }
  static Json object() { Json j; j.type_ = Type::Object; return j; }
  template <class T>
  static Json array_of(const T* v, size_t n) {
    Json j = array();
    for (size_t i = 0; i < n; ++i) j.push(Json(v[i]));
    return j;
  }

  Type type() const { return type_; }
  bool is_null() const { return type_ == Type::Null; }
  bool is_number() const { return type_ == Type::Number; }
  bool is_string() const { return type_ == Type::String; }
  bool is_object() const { return type_ == Type::Object; }
  bool is_array() const { return type_ == Type::Array; }
  bool as_bool() const { return b_; }
  double as_number() const { return num_; }
  const std::string& as_string() const { return str_; }

  // Arrays.
  Json& push(Json v);
  size_t size() const { return type_ == Type::Array ? arr_.size() : obj_.size(); }
  const Json& operator[](size_t i) const { return arr_[i]; }

  // Objects: set replaces an existing key (keeping its place) or appends.
  Json& set(const std::string& key, Json v);
  const Json* get(const std::string& key) const;  // nullptr if absent / not an object
  const std::vector<std::pair<std::string, Json>>& items() const { return obj_; }

  // Serialises with `indent` spaces per level (0: one line).
  std::string dump(int indent = 2) const;

 private:
  void dump_to(std::string* out, int indent, int level) const;
  Type type_ = Type::Null;
  bool b_ = false;
  double num_ = 0;
  bool integral_ = false;
  int64_t i_ = 0;
  std::string str_;
  std::vector<Json> arr_;
  std::vector<std::pair<std::string, Json>> obj_;
};

// Strict RFC 8259 parser (UTF-8 passes through; \u escapes become UTF-8).
// false with *err (position and reason) on malformed text.
bool json_parse(const std::string& text, Json* out, std::string* err);

// The string as a quoted JSON string literal.
std::string json_quote(const std::string& s);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_REPORT_JSON_H
