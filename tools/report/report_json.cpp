// JSON value, writer and parser for the tools (see report_json.h).
#include "report_json.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace ffseg_tools {

Json& Json::push(Json v) {
  if (type_ != Type::Array) *this = array();
  arr_.push_back(std::move(v));
  return arr_.back();
}

Json& Json::set(const std::string& key, Json v) {
  if (type_ != Type::Object) *this = object();
  for (auto& kv : obj_)
    if (kv.first == key) {
      kv.second = std::move(v);
      return kv.second;
    }
  obj_.emplace_back(key, std::move(v));
  return obj_.back().second;
}

const Json* Json::get(const std::string& key) const {
  if (type_ != Type::Object) return nullptr;
  for (const auto& kv : obj_)
    if (kv.first == key) return &kv.second;
  return nullptr;
}

std::string json_quote(const std::string& s) {
  std::string r = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"': r += "\\\""; break;
      case '\\': r += "\\\\"; break;
      case '\n': r += "\\n"; break;
      case '\r': r += "\\r"; break;
      case '\t': r += "\\t"; break;
      case '\b': r += "\\b"; break;
      case '\f': r += "\\f"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          r += buf;
        } else {
          r += char(c);
        }
    }
  }
  return r + "\"";
}

namespace {
// Shortest "%.*g" that reads back to the same double.
std::string format_number(double v) {
  char buf[40];
  for (int prec = 6; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}
}  // namespace

void Json::dump_to(std::string* out, int indent, int level) const {
  const auto newline = [&](int lv) {
    if (indent <= 0) return;
    *out += '\n';
    out->append(size_t(indent) * size_t(lv), ' ');
  };
  switch (type_) {
    case Type::Null: *out += "null"; break;
    case Type::Bool: *out += b_ ? "true" : "false"; break;
    case Type::Number:
      if (integral_) *out += std::to_string(i_);
      else if (!std::isfinite(num_)) *out += "null";
      else *out += format_number(num_);
      break;
    case Type::String: *out += json_quote(str_); break;
    case Type::Array: {
      // Arrays of plain numbers stay on one line (vectors, matrices rows).
      bool flat = true;
      for (const Json& v : arr_) flat = flat && (v.type_ == Type::Number || v.type_ == Type::Null ||
                                                 v.type_ == Type::Bool);
      *out += '[';
      for (size_t i = 0; i < arr_.size(); ++i) {
        if (i) *out += flat ? ", " : ",";
        if (!flat) newline(level + 1);
        arr_[i].dump_to(out, indent, level + 1);
      }
      if (!flat && !arr_.empty()) newline(level);
      *out += ']';
      break;
    }
    case Type::Object:
      *out += '{';
      for (size_t i = 0; i < obj_.size(); ++i) {
        if (i) *out += ',';
        newline(level + 1);
        *out += json_quote(obj_[i].first);
        *out += indent > 0 ? ": " : ":";
        obj_[i].second.dump_to(out, indent, level + 1);
      }
      if (!obj_.empty()) newline(level);
      *out += '}';
      break;
  }
}

std::string Json::dump(int indent) const {
  std::string s;
  dump_to(&s, indent, 0);
  if (indent > 0) s += '\n';
  return s;
}

namespace {

struct Parser {
  const std::string& s;
  size_t p = 0;
  std::string err;
  int depth = 0;

  bool fail(const std::string& m) {
    if (err.empty()) err = "JSON at offset " + std::to_string(p) + ": " + m;
    return false;
  }
  void ws() {
    while (p < s.size() && (s[p] == ' ' || s[p] == '\t' || s[p] == '\n' || s[p] == '\r')) ++p;
  }
  bool lit(const char* w) {
    const size_t n = std::strlen(w);
    if (s.compare(p, n, w) != 0) return false;
    p += n;
    return true;
  }
  static void utf8(std::string* o, uint32_t cp) {
    if (cp < 0x80) {
      *o += char(cp);
    } else if (cp < 0x800) {
      *o += char(0xC0 | (cp >> 6));
      *o += char(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      *o += char(0xE0 | (cp >> 12));
      *o += char(0x80 | ((cp >> 6) & 0x3F));
      *o += char(0x80 | (cp & 0x3F));
    } else {
      *o += char(0xF0 | (cp >> 18));
      *o += char(0x80 | ((cp >> 12) & 0x3F));
      *o += char(0x80 | ((cp >> 6) & 0x3F));
      *o += char(0x80 | (cp & 0x3F));
    }
  }
  bool hex4(uint32_t* v) {
    if (p + 4 > s.size()) return fail("truncated \\u escape");
    *v = 0;
    for (int i = 0; i < 4; ++i) {
      const char c = s[p++];
      *v <<= 4;
      if (c >= '0' && c <= '9') *v |= uint32_t(c - '0');
      else if (c >= 'a' && c <= 'f') *v |= uint32_t(c - 'a' + 10);
      else if (c >= 'A' && c <= 'F') *v |= uint32_t(c - 'A' + 10);
      else return fail("bad \\u escape");
    }
    return true;
  }
  bool string(std::string* o) {
    if (p >= s.size() || s[p] != '"') return fail("expected a string");
    ++p;
    for (;;) {
      if (p >= s.size()) return fail("unterminated string");
      const unsigned char c = static_cast<unsigned char>(s[p++]);
      if (c == '"') return true;
      if (c < 0x20) return fail("control character in string");
      if (c != '\\') {
        *o += char(c);
        continue;
      }
      if (p >= s.size()) return fail("unterminated escape");
      const char e = s[p++];
      switch (e) {
        case '"': *o += '"'; break;
        case '\\': *o += '\\'; break;
        case '/': *o += '/'; break;
        case 'b': *o += '\b'; break;
        case 'f': *o += '\f'; break;
        case 'n': *o += '\n'; break;
        case 'r': *o += '\r'; break;
        case 't': *o += '\t'; break;
        case 'u': {
          uint32_t cp = 0;  // hex4 sets it before any read (GCC at -O3 warns it may not)
          if (!hex4(&cp)) return false;
          if (cp >= 0xD800 && cp < 0xDC00) {
            uint32_t lo = 0;
            if (!lit("\\u") || !hex4(&lo) || lo < 0xDC00 || lo >= 0xE000)
              return fail("unpaired surrogate");
            cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
          } else if (cp >= 0xDC00 && cp < 0xE000) {
            return fail("unpaired surrogate");
          }
          utf8(o, cp);
          break;
        }
        default: return fail("bad escape");
      }
    }
  }
  bool number(Json* out) {
    const size_t start = p;
    if (p < s.size() && s[p] == '-') ++p;
    if (p >= s.size() || !std::isdigit(static_cast<unsigned char>(s[p]))) return fail("bad number");
    if (s[p] == '0') ++p;
    else while (p < s.size() && std::isdigit(static_cast<unsigned char>(s[p]))) ++p;
    bool integral = true;
    if (p < s.size() && s[p] == '.') {
      integral = false;
      ++p;
      if (p >= s.size() || !std::isdigit(static_cast<unsigned char>(s[p]))) return fail("bad fraction");
      while (p < s.size() && std::isdigit(static_cast<unsigned char>(s[p]))) ++p;
    }
    if (p < s.size() && (s[p] == 'e' || s[p] == 'E')) {
      integral = false;
      ++p;
      if (p < s.size() && (s[p] == '+' || s[p] == '-')) ++p;
      if (p >= s.size() || !std::isdigit(static_cast<unsigned char>(s[p]))) return fail("bad exponent");
      while (p < s.size() && std::isdigit(static_cast<unsigned char>(s[p]))) ++p;
    }
    const std::string t = s.substr(start, p - start);
    if (integral && t.size() < 18) *out = Json(int64_t(std::strtoll(t.c_str(), nullptr, 10)));
    else *out = Json(std::strtod(t.c_str(), nullptr));
    return true;
  }
  bool value(Json* out) {
    if (++depth > 200) return fail("nesting too deep");
    ws();
    if (p >= s.size()) return fail("unexpected end");
    bool ok = true;
    const char c = s[p];
    if (c == '{') {
      ++p;
      *out = Json::object();
      ws();
      if (p < s.size() && s[p] == '}') {
        ++p;
      } else {
        for (;;) {
          ws();
          std::string k;
          if (!string(&k)) return false;
          ws();
          if (p >= s.size() || s[p] != ':') return fail("expected ':'");
          ++p;
          Json v;
          if (!value(&v)) return false;
          out->set(k, std::move(v));
          ws();
          if (p < s.size() && s[p] == ',') { ++p; continue; }
          if (p < s.size() && s[p] == '}') { ++p; break; }
          return fail("expected ',' or '}'");
        }
      }
    } else if (c == '[') {
      ++p;
      *out = Json::array();
      ws();
      if (p < s.size() && s[p] == ']') {
        ++p;
      } else {
        for (;;) {
          Json v;
          if (!value(&v)) return false;
          out->push(std::move(v));
          ws();
          if (p < s.size() && s[p] == ',') { ++p; continue; }
          if (p < s.size() && s[p] == ']') { ++p; break; }
          return fail("expected ',' or ']'");
        }
      }
    } else if (c == '"') {
      std::string str;
      ok = string(&str);
      *out = Json(std::move(str));
    } else if (lit("true")) {
      *out = Json(true);
    } else if (lit("false")) {
      *out = Json(false);
    } else if (lit("null")) {
      *out = Json();
    } else {
      ok = number(out);
    }
    --depth;
    return ok;
  }
};

}  // namespace

bool json_parse(const std::string& text, Json* out, std::string* err) {
  Parser ps{text, 0, std::string(), 0};
  Json v;
  bool ok = ps.value(&v);
  if (ok) {
    ps.ws();
    if (ps.p != text.size()) ok = ps.fail("trailing characters");
  }
  if (!ok) {
    if (err) *err = ps.err;
    return false;
  }
  *out = std::move(v);
  return true;
}

}  // namespace ffseg_tools
