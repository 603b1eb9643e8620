// Shared helpers of the `ffseg` tool (see cli.h).
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "cli.h"
#include "metrics.h"

namespace ffseg_cli {

using ffseg_tools::NiftiImage;

void fail(int code, const std::string& message) { throw CliError{code, message}; }

// ---- command line -----------------------------------------------------------
Args::Args(int argc, char** argv, int first) {
  for (int i = first; i < argc; ++i) a_.emplace_back(argv[i]);
}

bool Args::next(std::string* token, bool* is_option) {
  if (have_inline_) fail(kExitUsage, "option " + *token + " takes no value");
  if (i_ >= a_.size()) return false;
  std::string t = a_[i_++];
  if (!only_positional_ && t == "--") {
    only_positional_ = true;
    return next(token, is_option);
  }
  *is_option = !only_positional_ && t.size() > 1 && t[0] == '-' &&
               !(std::isdigit(static_cast<unsigned char>(t[1])) || t[1] == '.');
  if (*is_option && t.rfind("--", 0) == 0) {
    const size_t eq = t.find('=');
    if (eq != std::string::npos) {
      inline_value_ = t.substr(eq + 1);
      have_inline_ = true;
      t = t.substr(0, eq);
    }
  }
  *token = t;
  return true;
}

std::string Args::value(const std::string& option) {
  if (have_inline_) {
    have_inline_ = false;
    return inline_value_;
  }
  if (i_ >= a_.size()) fail(kExitUsage, "option " + option + " needs a value");
  return a_[i_++];
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  size_t start = 0;
  for (;;) {
    const size_t p = s.find(sep, start);
    out.push_back(s.substr(start, p == std::string::npos ? std::string::npos : p - start));
    if (p == std::string::npos) break;
    start = p + 1;
  }
  return out;
}

double parse_double(const std::string& s, const std::string& what) {
  const char* b = s.c_str();
  while (*b == ' ') ++b;
  char* e = nullptr;
  errno = 0;
  const double v = std::strtod(b, &e);
  if (*b == '\0' || e == b || *e != '\0' || errno == ERANGE || !std::isfinite(v))
    fail(kExitUsage, what + ": '" + s + "' is not a finite number");
  return v;
}

int64_t parse_int(const std::string& s, const std::string& what, int64_t lo, int64_t hi) {
  char* e = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &e, 10);
  if (s.empty() || *e != '\0' || errno == ERANGE || std::isspace(static_cast<unsigned char>(s[0])))
    fail(kExitUsage, what + ": '" + s + "' is not an integer");
  if (v < lo || v > hi)
    fail(kExitUsage, what + ": " + s + " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

std::string format_double(double v, int digits) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}

// ---- images -------------------------------------------------------------------
NiftiImage read_image(const std::string& path, ffseg_tools::ImageFormat* format, ffseg_tools::DicomSource* dicom) {
  NiftiImage img;
  std::string err;
  if (ffseg_tools::image_read_file(path, &img, format, &err, {}, dicom)) return img;
  fail(kExitInput, "cannot read " + path + ": " + err);
}

double voxel_value(const NiftiImage& img, size_t i) {
  const uint8_t* d = img.data.data();
  double v = 0;
  switch (img.voxel_type) {
    case ffseg_tools::kNiftiVoxU8: v = d[i]; break;
    case ffseg_tools::kNiftiVoxI16: { int16_t x; std::memcpy(&x, d + 2 * i, 2); v = x; break; }
    case ffseg_tools::kNiftiVoxU16: { uint16_t x; std::memcpy(&x, d + 2 * i, 2); v = x; break; }
    case ffseg_tools::kNiftiVoxI32: { int32_t x; std::memcpy(&x, d + 4 * i, 4); v = x; break; }
    case ffseg_tools::kNiftiVoxF32: { float x; std::memcpy(&x, d + 4 * i, 4); v = x; break; }
    case ffseg_tools::kNiftiVoxF64: std::memcpy(&v, d + 8 * i, 8); break;
    default: break;
  }
  return img.scl_slope * v + img.scl_inter;
}

std::vector<uint8_t> label_mask(const NiftiImage& img, int64_t label, size_t* count) {
  std::vector<uint8_t> m(size_t(img.voxel_count()), 0);
  size_t n = 0;
  const double a = img.scl_slope, b = img.scl_inter, want = double(label);
  for_each_stored(img, [&](size_t i, double v) {
    const double x = a * v + b;
    if (std::fabs(x - want) < 1e-3) {
      m[i] = 1;
      ++n;
    }
  });
  if (count) *count = n;
  return m;
}

double voxel_volume_mm3(const NiftiImage& img) {
  const double* m = img.index_to_world;
  const double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                     m[2] * (m[4] * m[9] - m[5] * m[8]);
  return std::fabs(det);
}

std::array<double, 3> voxel_to_world(const double A[16], const double ijk[3]) {
  std::array<double, 3> w;
  for (int r = 0; r < 3; ++r)
    w[size_t(r)] = A[4 * r] * ijk[0] + A[4 * r + 1] * ijk[1] + A[4 * r + 2] * ijk[2] + A[4 * r + 3];
  return w;
}

std::array<double, 3> world_to_voxel(const double A[16], const double xyz[3]) {
  const double a = A[0], b = A[1], c = A[2], d = A[4], e = A[5], f = A[6], g = A[8], h = A[9], i = A[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  const double inv[9] = {(e * i - f * h) / det,  -(b * i - c * h) / det, (b * f - c * e) / det,
                         -(d * i - f * g) / det, (a * i - c * g) / det,  -(a * f - c * d) / det,
                         (d * h - e * g) / det,  -(a * h - b * g) / det, (a * e - b * d) / det};
  const double p[3] = {xyz[0] - A[3], xyz[1] - A[7], xyz[2] - A[11]};
  std::array<double, 3> v;
  for (int r = 0; r < 3; ++r) v[size_t(r)] = inv[3 * r] * p[0] + inv[3 * r + 1] * p[1] + inv[3 * r + 2] * p[2];
  return v;
}

std::string orientation_code(const double A[16]) {
  static const char pos[3] = {'R', 'A', 'S'}, neg[3] = {'L', 'P', 'I'};
  std::string s;
  for (int c = 0; c < 3; ++c) {
    int best = 0;
    for (int r = 1; r < 3; ++r)
      if (std::fabs(A[4 * r + c]) > std::fabs(A[4 * best + c])) best = r;
    s += A[4 * best + c] >= 0 ? pos[best] : neg[best];
  }
  return s;
}

const char* datatype_name(int dt) {
  switch (dt) {
    case ffseg_tools::kNiftiDtUint8: return "uint8";
    case ffseg_tools::kNiftiDtInt16: return "int16";
    case ffseg_tools::kNiftiDtInt32: return "int32";
    case ffseg_tools::kNiftiDtFloat32: return "float32";
    case ffseg_tools::kNiftiDtFloat64: return "float64";
    case ffseg_tools::kNiftiDtInt8: return "int8";
    case ffseg_tools::kNiftiDtUint16: return "uint16";
    case ffseg_tools::kNiftiDtUint32: return "uint32";
    case ffseg_tools::kNiftiDtInt64: return "int64";
    case ffseg_tools::kNiftiDtUint64: return "uint64";
    default: return "unknown";
  }
}

MaskMetrics compare_masks_cropped(const uint8_t* a, const uint8_t* b, const int dims[3],
                                  const double spacing[3]) {
  // Bounding box of A u B, grown by one voxel (clamped to the grid): the
  // border voxels and their distances are the same as on the whole grid.
  int lo[3] = {dims[0], dims[1], dims[2]}, hi[3] = {-1, -1, -1};
  size_t na = 0, nb = 0;
  const size_t sj = size_t(dims[0]), sk = size_t(dims[0]) * size_t(dims[1]);
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j) {
      const size_t row = size_t(k) * sk + size_t(j) * sj;
      for (int i = 0; i < dims[0]; ++i) {
        const bool ia = a[row + size_t(i)] != 0, ib = b[row + size_t(i)] != 0;
        na += ia;
        nb += ib;
        if (ia || ib) {
          lo[0] = std::min(lo[0], i); hi[0] = std::max(hi[0], i);
          lo[1] = std::min(lo[1], j); hi[1] = std::max(hi[1], j);
          lo[2] = std::min(lo[2], k); hi[2] = std::max(hi[2], k);
        }
      }
    }
  if (hi[0] < 0) {  // both empty: any 1-voxel grid gives the library's answer
    lo[0] = lo[1] = lo[2] = 0;
    hi[0] = hi[1] = hi[2] = 0;
  } else {
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::max(0, lo[d] - 1);
      hi[d] = std::min(dims[d] - 1, hi[d] + 1);
    }
  }
  const int cd[3] = {hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
  std::vector<uint8_t> ca(size_t(cd[0]) * size_t(cd[1]) * size_t(cd[2])), cb(ca.size());
  size_t q = 0;
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i, ++q) {
        const size_t idx = size_t(k) * sk + size_t(j) * sj + size_t(i);
        ca[q] = a[idx] != 0;
        cb[q] = b[idx] != 0;
      }
  const ffseg_tools::SegMetrics m = ffseg_tools::compare_masks(ca.data(), cb.data(), cd, spacing);
  MaskMetrics r;
  r.dice = m.dice;
  r.voe = m.voe;
  r.rvd = m.rvd;
  r.assd_mm = m.assd_mm;
  r.hd95_mm = m.hd95_mm;
  r.hd_mm = m.hd_mm;
  r.vol_a_ml = m.vol_a_ml;
  r.vol_b_ml = m.vol_b_ml;
  r.voxels_a = na;
  r.voxels_b = nb;
  return r;
}

// ---- files ----------------------------------------------------------------------
bool path_exists(const std::string& p) {
  struct stat st;
  return ::lstat(p.c_str(), &st) == 0;
}

bool is_directory(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool directory_is_empty(const std::string& p) {
  DIR* d = ::opendir(p.c_str());
  if (!d) return false;
  bool empty = true;
  while (const dirent* e = ::readdir(d)) {
    if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) {
      empty = false;
      break;
    }
  }
  ::closedir(d);
  return empty;
}

void remove_tree(const std::string& p) {
  struct stat st;
  if (::lstat(p.c_str(), &st) != 0) return;
  if (S_ISDIR(st.st_mode)) {
    if (DIR* d = ::opendir(p.c_str())) {
      std::vector<std::string> names;
      while (const dirent* e = ::readdir(d))
        if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) names.emplace_back(e->d_name);
      ::closedir(d);
      for (const std::string& n : names) remove_tree(p + "/" + n);
    }
    ::rmdir(p.c_str());
  } else {
    ::unlink(p.c_str());
  }
}

std::string base_name(const std::string& path) {
  std::string p = path;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  const size_t s = p.rfind('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}

std::string parent_dir(const std::string& path) {
  std::string p = path;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  const size_t s = p.rfind('/');
  if (s == std::string::npos) return ".";
  if (s == 0) return "/";
  return p.substr(0, s);
}

bool write_text_file(const std::string& path, const std::string& text, std::string* err) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    *err = "cannot create " + path + ": " + std::strerror(errno);
    return false;
  }
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) {
    *err = "cannot write " + path + ": " + std::strerror(errno);
    return false;
  }
  return true;
}

// ---- interruption -------------------------------------------------------------
namespace {
volatile std::sig_atomic_t g_interrupted = 0;
extern "C" void on_signal(int sig) {
  g_interrupted = sig;
  std::signal(sig, SIG_DFL);  // a second signal ends the process at once
}
}  // namespace

void install_interrupt_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

void check_interrupted() {
  if (g_interrupted) fail(kExitInterrupted, std::string("interrupted by ") +
                                                (g_interrupted == SIGINT ? "SIGINT" : "SIGTERM") +
                                                "; nothing was written");
}

}  // namespace ffseg_cli

namespace ffseg_cli {

void set_metric_fields(ffseg_tools::Json& j, const MaskMetrics& m) {
  j.set("dice", m.dice);
  j.set("voe", m.voe);
  j.set("rvd", m.rvd);
  j.set("assd_mm", m.assd_mm);
  j.set("hd95_mm", m.hd95_mm);
  j.set("hd_mm", m.hd_mm);
}

}  // namespace ffseg_cli
