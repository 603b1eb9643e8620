#include "report_html.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

#include "cli.h"

namespace ffseg_cli {
namespace {

bool read_bytes(const std::string& path, std::string* out, std::string* err) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    *err = "report.html: cannot read " + path;
    return false;
  }
  out->assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  return true;
}

std::string base64(const std::string& in) {
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(in[i])) << 16 | uint32_t(uint8_t(in[i + 1])) << 8 | uint8_t(in[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += kAlphabet[(v >> s) & 63];
  }
  if (i < in.size()) {
    const bool two = i + 1 < in.size();
    const uint32_t v = uint32_t(uint8_t(in[i])) << 16 | (two ? uint32_t(uint8_t(in[i + 1])) << 8 : 0);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += two ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// Text inside <script> ends at the first "</": JSON and names escape it.
std::string script_safe(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '<' && i + 1 < s.size() && s[i + 1] == '/') out += "<\\";
    else out += s[i];
  }
  return out;
}

std::string attribute(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"') out += "&quot;";
    else if (c == '&') out += "&amp;";
    else if (c == '<') out += "&lt;";
    else out += c;
  }
  return out;
}

// The volume formats the viewer opens from one file, by the name's ending.
bool viewer_reads(const std::string& path) {
  for (const char* ext : {".nii", ".nii.gz", ".nrrd", ".mha", ".mgh", ".mgz"}) {
    const std::string e = ext;
    if (path.size() > e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0) return true;
  }
  return false;
}

std::string embedded(const char* role, const std::string& name, const std::string& bytes) {
  return "<script type=\"application/octet-stream\" data-role=\"" + std::string(role) + "\" data-name=\"" +
         attribute(base_name(name)) + "\">" + base64(bytes) + "</script>\n";
}

}  // namespace

std::string find_report_viewer() {
  if (const char* env = std::getenv("FFSEG_VIEWER_JS")) return path_exists(env) ? env : "";
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return "";
  const std::string dir = parent_dir(std::string(exe, size_t(n)));
  for (const std::string& candidate : {dir + "/../web/dist/report-viewer.js", dir + "/../share/ffseg/report-viewer.js"})
    if (path_exists(candidate)) return candidate;
  return "";
}

bool write_report_html(const std::string& dir, const std::string& viewer_js, const std::string& volume_path,
                       const std::string& labels_file, const std::vector<std::string>& mesh_files,
                       const std::string& report_json, std::string* err) {
  std::string script, bytes;
  if (!read_bytes(viewer_js, &script, err)) return false;
  std::ostringstream html;
  html << "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>ffseg report</title>\n"
          "<link rel=\"icon\" href=\"data:,\">\n</head>\n<body>\n"
       << "<script type=\"application/json\" id=\"ffseg-report\">" << script_safe(report_json) << "</script>\n";
  if (viewer_reads(volume_path) && !is_directory(volume_path)) {
    if (!read_bytes(volume_path, &bytes, err)) return false;
    html << embedded("volume", volume_path, bytes);
  }
  if (!read_bytes(dir + "/" + labels_file, &bytes, err)) return false;
  html << embedded("labels", labels_file, bytes);
  for (const std::string& m : mesh_files) {
    if (!read_bytes(dir + "/" + m, &bytes, err)) return false;
    html << embedded("mesh", m, bytes);
  }
  html << "<script>" << script_safe(script) << "</script>\n</body>\n</html>\n";
  return write_text_file(dir + "/report.html", html.str(), err);
}

}  // namespace ffseg_cli
