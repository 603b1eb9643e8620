// ffseg tools: shared pieces of the image readers (see image_common.h).
#include "image_common.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace ffseg_tools {
namespace img {

using io::fail;
using io::fmt;

namespace {
constexpr ScalarType kTypes[] = {
    {"uint8", 1, kNiftiVoxU8, 1, kNiftiDtUint8},      {"int8", 1, kNiftiVoxI16, 2, kNiftiDtInt8},
    {"int16", 2, kNiftiVoxI16, 2, kNiftiDtInt16},     {"uint16", 2, kNiftiVoxU16, 2, kNiftiDtUint16},
    {"int32", 4, kNiftiVoxI32, 4, kNiftiDtInt32},     {"uint32", 4, kNiftiVoxF64, 8, kNiftiDtUint32},
    {"int64", 8, kNiftiVoxF64, 8, kNiftiDtInt64},     {"uint64", 8, kNiftiVoxF64, 8, kNiftiDtUint64},
    {"float32", 4, kNiftiVoxF32, 4, kNiftiDtFloat32}, {"float64", 8, kNiftiVoxF64, 8, kNiftiDtFloat64},
};

template <class From, class To>
void widen(const uint8_t* in, uint8_t* out, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        From v;
        std::memcpy(&v, in + i * sizeof(From), sizeof v);
        const To w = To(v);
        std::memcpy(out + i * sizeof(To), &w, sizeof w);
    }
}
}  // namespace

const ScalarType* scalar_type_by_name(const std::string& name) {
    for (const ScalarType& t : kTypes)
        if (name == t.name) return &t;
    return nullptr;
}

const ScalarType* scalar_type_of_voxel_type(int voxel_type) {
    static const char* const names[] = {nullptr, "uint8", "int16", "uint16", "int32", "float32", "float64"};
    if (voxel_type < 1 || voxel_type > 6) return nullptr;
    return scalar_type_by_name(names[voxel_type]);
}

bool read_voxels(Source& src, const ScalarType& t, bool big_endian, const int dims[3], const NiftiLimits& lim,
                 NiftiImage* img, const std::string& what, std::string* err) {
    for (int a = 0; a < 3; ++a)
        if (dims[a] < 1) return fail(err, fmt("dimension %d is %d (must be >= 1)", a, dims[a]));
    const uint64_t n = uint64_t(dims[0]) * uint64_t(dims[1]) * uint64_t(dims[2]);
    if (n > lim.max_bytes / uint64_t(t.out_bytes) || n * uint64_t(t.file_bytes) > lim.max_bytes)
        return fail(err, fmt("%llu voxels of %s exceed the reader's bound of %llu bytes", (unsigned long long)n,
                             t.name, (unsigned long long)lim.max_bytes));
    const uint64_t need = n * uint64_t(t.file_bytes);
    uint64_t left = 0;
    const bool known = src.remaining(&left);
    if (known && left < need)
        return fail(err, fmt("%s is too short: %llu bytes of voxels expected, %llu present", what.c_str(),
                             (unsigned long long)need, (unsigned long long)left));
    std::vector<uint8_t> raw;
    const size_t chunk = size_t(1) << 22;
    // One buffer for the whole volume where its size is vouched for (the
    // bytes are there) or likely (4x the compressed bytes left: volumes
    // deflate 2-5 to 1, as in the NIfTI reader); else it grows as data
    // arrives, so a lying header cannot make it allocate ahead of the data.
    uint64_t packed = 0;
    if (known) raw.reserve(size_t(need));
    else if (src.compressed_remaining(&packed)) raw.reserve(size_t(std::min<uint64_t>(need, std::max<uint64_t>(chunk, 4 * packed))));
    while (raw.size() < need) {
        const size_t want = size_t(std::min<uint64_t>(chunk, need - raw.size()));
        const size_t at = raw.size();
        raw.resize(at + want);
        size_t got = 0;
        if (!src.read(raw.data() + at, want, &got, err)) return false;
        raw.resize(at + got);
        if (got < want)
            return fail(err, fmt("%s ends early: %llu of %llu bytes of voxels", what.c_str(),
                                 (unsigned long long)raw.size(), (unsigned long long)need));
    }
    if (big_endian != host_is_big_endian()) io::swap_bytes_inplace(raw.data(), size_t(t.file_bytes), size_t(n));
    for (int a = 0; a < 3; ++a) img->dims[a] = dims[a];
    img->voxel_type = t.voxel_type;
    img->bytes_per_voxel = t.out_bytes;
    img->datatype = t.nifti_datatype;
    const std::string nm = t.name;
    if (nm != "int8" && nm != "uint32" && nm != "int64" && nm != "uint64") {
        img->data.swap(raw);
        return true;
    }
    img->data.assign(size_t(n) * size_t(t.out_bytes), 0);
    if (nm == "int8") widen<int8_t, int16_t>(raw.data(), img->data.data(), size_t(n));
    else if (nm == "uint32") widen<uint32_t, double>(raw.data(), img->data.data(), size_t(n));
    else if (nm == "int64") widen<int64_t, double>(raw.data(), img->data.data(), size_t(n));
    else if (nm == "uint64") widen<uint64_t, double>(raw.data(), img->data.data(), size_t(n));
    else return fail(err, fmt("internal: no conversion for %s", t.name));
    return true;
}

bool set_lps_geometry(const double axis[3][3], const double origin[3], NiftiImage* img, const char* source,
                      const char* field, std::string* err) {
    double m[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) {
            if (!std::isfinite(axis[c][r])) return fail(err, fmt("%s: not finite", field));
            m[4 * r + c] = (r < 2 ? -1.0 : 1.0) * axis[c][r];
        }
    for (int r = 0; r < 3; ++r) {
        if (!std::isfinite(origin[r])) return fail(err, fmt("%s: the origin is not finite", field));
        m[4 * r + 3] = (r < 2 ? -1.0 : 1.0) * origin[r];
    }
    double n[3];
    for (int c = 0; c < 3; ++c) n[c] = std::sqrt(m[c] * m[c] + m[4 + c] * m[4 + c] + m[8 + c] * m[8 + c]);
    const double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                       m[2] * (m[4] * m[9] - m[5] * m[8]);
    if (!(n[0] > 0 && n[1] > 0 && n[2] > 0) || !(std::fabs(det) > 1e-6 * n[0] * n[1] * n[2]))
        return fail(err, fmt("%s: the axes are singular (det %g)", field, det));
    std::memcpy(img->index_to_world, m, sizeof m);
    for (int a = 0; a < 3; ++a) {
        img->spacing[a] = n[a];
        img->pixdim[a + 1] = n[a];
    }
    img->pixdim[0] = det < 0 ? -1 : 1;
    img->which_affine = source;
    img->xyzt_units = 2;  // mm
    return true;
}

void lps_geometry(const NiftiImage& im, double axis[3][3], double origin[3]) {
    const double* m = im.index_to_world;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) axis[c][r] = (r < 2 ? -1.0 : 1.0) * m[4 * r + c];
    for (int r = 0; r < 3; ++r) origin[r] = (r < 2 ? -1.0 : 1.0) * m[4 * r + 3];
}

bool parse_double(const std::string& tok, double* v) {
    if (tok.empty() || std::isspace(static_cast<unsigned char>(tok[0]))) return false;
    char* e = nullptr;
    errno = 0;
    const double x = std::strtod(tok.c_str(), &e);
    if (e == tok.c_str() || *e != '\0' || errno == ERANGE || !std::isfinite(x)) return false;
    *v = x;
    return true;
}

bool parse_int64(const std::string& tok, int64_t lo, int64_t hi, int64_t* v) {
    if (tok.empty() || !(std::isdigit(static_cast<unsigned char>(tok[0])) || tok[0] == '-' || tok[0] == '+'))
        return false;
    char* e = nullptr;
    errno = 0;
    const long long x = std::strtoll(tok.c_str(), &e, 10);
    if (*e != '\0' || errno == ERANGE || x < lo || x > hi) return false;
    *v = x;
    return true;
}

std::vector<std::string> split_ws(const std::string& s) {
    std::vector<std::string> out;
    size_t i = 0;
    while (i < s.size()) {
        while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        size_t j = i;
        while (j < s.size() && !std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        if (j > i) out.push_back(s.substr(i, j - i));
        i = j;
    }
    return out;
}

std::string trim(const std::string& s) {
    size_t a = 0, b = s.size();
    while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
    while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
    return s.substr(a, b - a);
}

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

std::string exact(double v) { return fmt("%.17g", v); }

std::string dir_of(const std::string& path) {
    const size_t s = path.rfind('/');
    return s == std::string::npos ? std::string() : path.substr(0, s + 1);
}

std::string resolve_beside(const std::string& header_path, const std::string& name) {
    if (!name.empty() && name[0] == '/') return name;
    return dir_of(header_path) + name;
}

bool host_is_big_endian() {
    const uint16_t one = 1;
    uint8_t b;
    std::memcpy(&b, &one, 1);
    return b == 0;
}

bool LineSource::next(std::string* line, bool* end, std::string* err) {
    line->clear();
    *end = false;
    for (;;) {
        const int c = get();
        if (c < 0) {
            if (line->empty()) *end = true;
            break;
        }
        if (++total_ > (size_t(1) << 20)) return fail(err, "the header is longer than 1 MiB (is this a text header?)");
        if (c == '\n') break;
        if (c == 0) return fail(err, "the header holds a NUL byte (is this a text header?)");
        if (line->size() >= (size_t(1) << 16)) return fail(err, "a header line is longer than 64 KiB");
        line->push_back(char(c));
    }
    if (!line->empty() && line->back() == '\r') line->pop_back();
    return true;
}

}  // namespace img
}  // namespace ffseg_tools
