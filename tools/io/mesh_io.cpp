// Mesh file writers and readers (see mesh_io.h). Binary formats are written
// byte by byte in little-endian order, so the output does not depend on the host.
#include "mesh_io.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

namespace ffseg_tools {

namespace {

void put_u32(std::vector<uint8_t>& b, uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(uint8_t(v >> (8 * i)));
}
void put_u16(std::vector<uint8_t>& b, uint16_t v) {
  b.push_back(uint8_t(v));
  b.push_back(uint8_t(v >> 8));
}
void put_f32(std::vector<uint8_t>& b, float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  put_u32(b, u);
}
void put_text(std::vector<uint8_t>& b, const std::string& s) { b.insert(b.end(), s.begin(), s.end()); }

uint32_t get_u32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
float get_f32(const uint8_t* p) {
  const uint32_t u = get_u32(p);
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

// One line of comment: no line breaks, no control characters.
std::string one_line(const std::string& s) {
  std::string r;
  for (char c : s) r += (static_cast<unsigned char>(c) < 32 || c == 127) ? ' ' : c;
  return r;
}

std::string fmt_float(float f) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", double(f));
  return buf;
}

bool fail(std::string* err, const std::string& msg) {
  if (err) *err = msg;
  return false;
}

std::string trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

// A cursor over text split into whitespace-separated tokens, tracking lines.
struct TextReader {
  const char* p;
  const char* end;
  bool next_line(std::string* line) {
    if (p >= end) return false;
    const char* q = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
    if (!q) q = end;
    line->assign(p, q);
    if (!line->empty() && line->back() == '\r') line->pop_back();
    p = q < end ? q + 1 : end;
    return true;
  }
  // Next token (skipping whitespace and newlines); false at the end.
  bool token(std::string* t) {
    while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
    if (p >= end) return false;
    const char* q = p;
    while (q < end && !std::isspace(static_cast<unsigned char>(*q))) ++q;
    t->assign(p, q);
    p = q;
    return true;
  }
};

bool parse_float(const std::string& t, float* v) {
  if (t.empty()) return false;
  char* e = nullptr;
  const float f = std::strtof(t.c_str(), &e);
  if (e != t.c_str() + t.size() || !std::isfinite(f)) return false;
  *v = f;
  return true;
}
bool parse_u64(const std::string& t, uint64_t* v) {
  if (t.empty() || !std::isdigit(static_cast<unsigned char>(t[0]))) return false;
  char* e = nullptr;
  errno = 0;
  const unsigned long long x = std::strtoull(t.c_str(), &e, 10);
  if (e != t.c_str() + t.size() || errno) return false;
  *v = x;
  return true;
}

bool check_indices(const uint32_t* tris, size_t n_tris, size_t n_vertices, std::string* err) {
  for (size_t i = 0; i < 3 * n_tris; ++i)
    if (tris[i] >= n_vertices)
      return fail(err, "triangle " + std::to_string(i / 3) + " refers to vertex " +
                           std::to_string(tris[i]) + " of " + std::to_string(n_vertices));
  return true;
}

void encode_ply(const float* xyz, size_t nv, const uint32_t* tris, size_t nt,
                const std::string& comment, std::vector<uint8_t>* out) {
  std::string h = "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) h += "comment " + one_line(comment) + "\n";
  h += "element vertex " + std::to_string(nv) + "\n";
  h += "property float x\nproperty float y\nproperty float z\n";
  h += "element face " + std::to_string(nt) + "\n";
  h += "property list uchar int vertex_indices\nend_header\n";
  out->reserve(h.size() + nv * 12 + nt * 13);
  put_text(*out, h);
  for (size_t i = 0; i < 3 * nv; ++i) put_f32(*out, xyz[i]);
  for (size_t t = 0; t < nt; ++t) {
    out->push_back(3);
    for (int c = 0; c < 3; ++c) put_u32(*out, tris[3 * t + c]);
  }
}

void encode_stl(const float* xyz, const uint32_t* tris, size_t nt, const std::string& comment,
                std::vector<uint8_t>* out) {
  // The header must not start with "solid" (some readers then expect ASCII).
  std::string h = "binary STL written by ffseg";
  if (!comment.empty()) h += "; " + one_line(comment);
  h.resize(80, ' ');
  out->reserve(84 + nt * 50);
  put_text(*out, h);
  put_u32(*out, uint32_t(nt));
  for (size_t t = 0; t < nt; ++t) {
    const float* a = xyz + 3 * size_t(tris[3 * t]);
    const float* b = xyz + 3 * size_t(tris[3 * t + 1]);
    const float* c = xyz + 3 * size_t(tris[3 * t + 2]);
    const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (double& x : n) x = len > 0 ? x / len : 0.0;
    for (double x : n) put_f32(*out, float(x));
    for (const float* p : {a, b, c})
      for (int k = 0; k < 3; ++k) put_f32(*out, p[k]);
    put_u16(*out, 0);
  }
}

void encode_obj(const float* xyz, size_t nv, const uint32_t* tris, size_t nt,
                const std::string& comment, std::vector<uint8_t>* out) {
  std::string s = "# Wavefront OBJ written by ffseg\n";
  if (!comment.empty()) s += "# " + one_line(comment) + "\n";
  s += "# " + std::to_string(nv) + " vertices, " + std::to_string(nt) + " triangles\n";
  s.reserve(s.size() + nv * 40 + nt * 24);
  for (size_t i = 0; i < nv; ++i)
    s += "v " + fmt_float(xyz[3 * i]) + " " + fmt_float(xyz[3 * i + 1]) + " " +
         fmt_float(xyz[3 * i + 2]) + "\n";
  for (size_t t = 0; t < nt; ++t)
    s += "f " + std::to_string(uint64_t(tris[3 * t]) + 1) + " " +
         std::to_string(uint64_t(tris[3 * t + 1]) + 1) + " " +
         std::to_string(uint64_t(tris[3 * t + 2]) + 1) + "\n";
  put_text(*out, s);
}

void encode_vtk(const float* xyz, size_t nv, const uint32_t* tris, size_t nt,
                const std::string& comment, std::vector<uint8_t>* out) {
  // The title line holds at most 256 characters.
  std::string title = "ffseg mesh";
  if (!comment.empty()) title += " " + one_line(comment);
  if (title.size() > 255) title.resize(255);
  std::string s = "# vtk DataFile Version 3.0\n" + title + "\nASCII\nDATASET POLYDATA\n";
  s += "POINTS " + std::to_string(nv) + " float\n";
  s.reserve(s.size() + nv * 40 + nt * 24);
  for (size_t i = 0; i < nv; ++i)
    s += fmt_float(xyz[3 * i]) + " " + fmt_float(xyz[3 * i + 1]) + " " + fmt_float(xyz[3 * i + 2]) + "\n";
  s += "POLYGONS " + std::to_string(nt) + " " + std::to_string(4 * nt) + "\n";
  for (size_t t = 0; t < nt; ++t)
    s += "3 " + std::to_string(tris[3 * t]) + " " + std::to_string(tris[3 * t + 1]) + " " +
         std::to_string(tris[3 * t + 2]) + "\n";
  put_text(*out, s);
}

bool decode_ply(const uint8_t* data, size_t size, MeshData* m, std::string* err) {
  TextReader r{reinterpret_cast<const char*>(data), reinterpret_cast<const char*>(data) + size};
  std::string line;
  if (!r.next_line(&line) || line != "ply") return fail(err, "PLY: missing 'ply' magic line");
  uint64_t nv = 0, nf = 0;
  bool have_format = false, have_v = false, have_f = false, in_vertex = false;
  int vertex_props = 0;
  for (;;) {
    if (!r.next_line(&line)) return fail(err, "PLY: header without end_header");
    if (line == "end_header") break;
    if (line.rfind("format ", 0) == 0) {
      if (line != "format binary_little_endian 1.0")
        return fail(err, "PLY: only 'format binary_little_endian 1.0' is read, not '" + line + "'");
      have_format = true;
    } else if (line.rfind("comment ", 0) == 0) {
      if (m->comment.empty()) m->comment = trim(line.substr(8));
    } else if (line.rfind("element vertex ", 0) == 0) {
      if (!parse_u64(line.substr(15), &nv)) return fail(err, "PLY: bad vertex count");
      have_v = in_vertex = true;
    } else if (line.rfind("element face ", 0) == 0) {
      if (!parse_u64(line.substr(13), &nf)) return fail(err, "PLY: bad face count");
      have_f = true;
      in_vertex = false;
    } else if (line.rfind("property ", 0) == 0) {
      if (in_vertex) {
        static const char* want[3] = {"property float x", "property float y", "property float z"};
        if (vertex_props >= 3 || line != want[vertex_props])
          return fail(err, "PLY: unexpected vertex property '" + line + "'");
        ++vertex_props;
      } else if (line != "property list uchar int vertex_indices" &&
                 line != "property list uchar uint vertex_indices") {
        return fail(err, "PLY: unexpected face property '" + line + "'");
      }
    } else if (line.rfind("obj_info", 0) != 0) {
      return fail(err, "PLY: unexpected header line '" + line + "'");
    }
  }
  if (!have_format || !have_v || !have_f || vertex_props != 3)
    return fail(err, "PLY: header lacks format, vertex x/y/z or face element");
  const size_t off = size_t(r.p - reinterpret_cast<const char*>(data));
  if (nv > (size - off) / 12 || nf > (size - off) / 13) return fail(err, "PLY: file too short");
  const size_t need = off + size_t(nv) * 12 + size_t(nf) * 13;
  if (need > size) return fail(err, "PLY: file too short for the counts in its header");
  m->xyz.resize(size_t(3 * nv));
  const uint8_t* p = data + off;
  for (size_t i = 0; i < 3 * nv; ++i, p += 4) m->xyz[i] = get_f32(p);
  m->tris.resize(size_t(3 * nf));
  for (size_t t = 0; t < nf; ++t) {
    if (*p != 3) return fail(err, "PLY: face " + std::to_string(t) + " is not a triangle");
    ++p;
    for (int c = 0; c < 3; ++c, p += 4) m->tris[3 * t + c] = get_u32(p);
  }
  return check_indices(m->tris.data(), size_t(nf), size_t(nv), err);
}

bool decode_stl(const uint8_t* data, size_t size, MeshData* m, std::string* err) {
  if (size < 84) return fail(err, "STL: shorter than the 84-byte binary header");
  const uint32_t nt = get_u32(data + 80);
  if ((size - 84) / 50 < nt || size - 84 != size_t(nt) * 50)
    return fail(err, "STL: size does not match a binary STL of " + std::to_string(nt) +
                         " triangles (ASCII STL is not read)");
  m->comment = trim(std::string(reinterpret_cast<const char*>(data), 80).c_str());
  m->xyz.resize(size_t(nt) * 9);
  m->tris.resize(size_t(nt) * 3);
  const uint8_t* p = data + 84;
  for (size_t t = 0; t < nt; ++t, p += 50) {
    for (int k = 0; k < 9; ++k) m->xyz[9 * t + k] = get_f32(p + 12 + 4 * k);
    for (int c = 0; c < 3; ++c) m->tris[3 * t + c] = uint32_t(3 * t + c);
  }
  return true;
}

bool decode_obj(const uint8_t* data, size_t size, MeshData* m, std::string* err) {
  TextReader r{reinterpret_cast<const char*>(data), reinterpret_cast<const char*>(data) + size};
  std::string line;
  size_t lineno = 0;
  bool first_comment = true;
  while (r.next_line(&line)) {
    ++lineno;
    TextReader lr{line.data(), line.data() + line.size()};
    std::string t;
    if (!lr.token(&t)) continue;
    if (t[0] == '#') {
      // The writer's first line is fixed text; the second holds the comment.
      if (!first_comment && m->comment.empty()) m->comment = trim(line.substr(1));
      first_comment = false;
      continue;
    }
    if (t == "v") {
      for (int k = 0; k < 3; ++k) {
        float f;
        if (!lr.token(&t) || !parse_float(t, &f))
          return fail(err, "OBJ line " + std::to_string(lineno) + ": bad vertex");
        m->xyz.push_back(f);
      }
    } else if (t == "f") {
      int n = 0;
      while (lr.token(&t)) {
        uint64_t idx;
        // "a/b/c" forms: the vertex index is before the first slash.
        const std::string v = t.substr(0, t.find('/'));
        if (!parse_u64(v, &idx) || idx == 0 || idx > std::numeric_limits<uint32_t>::max())
          return fail(err, "OBJ line " + std::to_string(lineno) + ": bad face index '" + t + "'");
        m->tris.push_back(uint32_t(idx - 1));
        ++n;
      }
      if (n != 3) return fail(err, "OBJ line " + std::to_string(lineno) + ": face is not a triangle");
    } else {
      return fail(err, "OBJ line " + std::to_string(lineno) + ": unsupported statement '" + t + "'");
    }
  }
  return check_indices(m->tris.data(), m->tris.size() / 3, m->xyz.size() / 3, err);
}

bool decode_vtk(const uint8_t* data, size_t size, MeshData* m, std::string* err) {
  TextReader r{reinterpret_cast<const char*>(data), reinterpret_cast<const char*>(data) + size};
  std::string line;
  if (!r.next_line(&line) || line.rfind("# vtk DataFile Version", 0) != 0)
    return fail(err, "VTK: missing '# vtk DataFile Version' line");
  if (!r.next_line(&line)) return fail(err, "VTK: missing title line");
  m->comment = trim(line);
  if (!r.next_line(&line) || trim(line) != "ASCII") return fail(err, "VTK: only ASCII files are read");
  std::string t;
  if (!r.token(&t) || t != "DATASET" || !r.token(&t) || t != "POLYDATA")
    return fail(err, "VTK: expected DATASET POLYDATA");
  uint64_t nv = 0, np = 0, total = 0;
  if (!r.token(&t) || t != "POINTS" || !r.token(&t) || !parse_u64(t, &nv) || !r.token(&t) ||
      (t != "float" && t != "double"))
    return fail(err, "VTK: expected POINTS n float");
  if (nv > size) return fail(err, "VTK: point count larger than the file");
  m->xyz.resize(size_t(3 * nv));
  for (size_t i = 0; i < 3 * nv; ++i)
    if (!r.token(&t) || !parse_float(t, &m->xyz[i])) return fail(err, "VTK: bad point coordinate");
  if (!r.token(&t) || t != "POLYGONS" || !r.token(&t) || !parse_u64(t, &np) || !r.token(&t) ||
      !parse_u64(t, &total))
    return fail(err, "VTK: expected POLYGONS n size");
  if (np > size || total != 4 * np) return fail(err, "VTK: only triangle polygons are read");
  m->tris.resize(size_t(3 * np));
  for (size_t p = 0; p < np; ++p) {
    uint64_t k;
    if (!r.token(&t) || !parse_u64(t, &k) || k != 3) return fail(err, "VTK: polygon is not a triangle");
    for (int c = 0; c < 3; ++c) {
      if (!r.token(&t) || !parse_u64(t, &k) || k >= nv) return fail(err, "VTK: bad polygon index");
      m->tris[3 * p + c] = uint32_t(k);
    }
  }
  return true;
}

}  // namespace

bool mesh_format_from_name(const std::string& name, MeshFormat* out) {
  std::string s;
  for (char c : name) s += char(std::tolower(static_cast<unsigned char>(c)));
  if (s == "ply") *out = MeshFormat::Ply;
  else if (s == "stl") *out = MeshFormat::Stl;
  else if (s == "obj") *out = MeshFormat::Obj;
  else if (s == "vtk") *out = MeshFormat::Vtk;
  else return false;
  return true;
}

const char* mesh_format_extension(MeshFormat f) {
  switch (f) {
    case MeshFormat::Ply: return "ply";
    case MeshFormat::Stl: return "stl";
    case MeshFormat::Obj: return "obj";
    case MeshFormat::Vtk: return "vtk";
  }
  return "";
}

bool mesh_encode(MeshFormat f, const float* xyz, size_t nv, const uint32_t* tris, size_t nt,
                 const std::string& comment, std::vector<uint8_t>* out, std::string* err) {
  out->clear();
  if ((nv && !xyz) || (nt && !tris)) return fail(err, "mesh_encode: null buffer");
  if (nv > std::numeric_limits<uint32_t>::max() || nt > std::numeric_limits<uint32_t>::max() / 3)
    return fail(err, "mesh too large for 32-bit counts");
  if (!check_indices(tris, nt, nv, err)) return false;
  switch (f) {
    case MeshFormat::Ply: encode_ply(xyz, nv, tris, nt, comment, out); break;
    case MeshFormat::Stl: encode_stl(xyz, tris, nt, comment, out); break;
    case MeshFormat::Obj: encode_obj(xyz, nv, tris, nt, comment, out); break;
    case MeshFormat::Vtk: encode_vtk(xyz, nv, tris, nt, comment, out); break;
  }
  return true;
}

bool mesh_write_file(const std::string& path, MeshFormat f, const float* xyz, size_t nv,
                     const uint32_t* tris, size_t nt, const std::string& comment, std::string* err) {
  std::vector<uint8_t> bytes;
  if (!mesh_encode(f, xyz, nv, tris, nt, comment, &bytes, err)) return false;
  std::FILE* fp = std::fopen(path.c_str(), "wb");
  if (!fp) return fail(err, "cannot create " + path + ": " + std::strerror(errno));
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), fp) == bytes.size();
  const int saved = errno;
  if (std::fclose(fp) != 0 || !ok) {
    std::remove(path.c_str());
    return fail(err, "cannot write " + path + ": " + std::strerror(ok ? errno : saved));
  }
  return true;
}

bool mesh_decode(MeshFormat f, const uint8_t* data, size_t size, MeshData* out, std::string* err) {
  *out = MeshData{};
  switch (f) {
    case MeshFormat::Ply: return decode_ply(data, size, out, err);
    case MeshFormat::Stl: return decode_stl(data, size, out, err);
    case MeshFormat::Obj: return decode_obj(data, size, out, err);
    case MeshFormat::Vtk: return decode_vtk(data, size, out, err);
  }
  return fail(err, "unknown mesh format");
}

bool mesh_read_file(const std::string& path, MeshFormat f, MeshData* out, std::string* err) {
  std::FILE* fp = std::fopen(path.c_str(), "rb");
  if (!fp) return fail(err, "cannot open " + path + ": " + std::strerror(errno));
  std::vector<uint8_t> bytes;
  uint8_t buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, fp)) > 0) bytes.insert(bytes.end(), buf, buf + n);
  const bool bad = std::ferror(fp) != 0;
  std::fclose(fp);
  if (bad) return fail(err, "cannot read " + path);
  return mesh_decode(f, bytes.data(), bytes.size(), out, err);
}

}  // namespace ffseg_tools
