// ffseg tools: strict NRRD reader and writer (see nrrd.h for the policy).
#include "nrrd.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>

#include "byte_io.h"
#include "image_common.h"

namespace ffseg_tools {
namespace {

using namespace io;
using namespace img;

enum Space { kNoSpace, kRAS, kLAS, kLPS };

struct Header {
    int version = 0;
    const ScalarType* type = nullptr;
    std::string type_text;
    int64_t dimension = 0;
    int sizes[3] = {0, 0, 0};
    bool have_sizes = false;
    std::string encoding;
    bool have_endian = false, big_endian = false;
    Space space = kNoSpace;
    bool have_dirs = false, have_origin = false, have_spacings = false;
    double dirs[3][3] = {{0}}, origin[3] = {0, 0, 0}, spacings[3] = {1, 1, 1};
    std::string data_file;
    int64_t line_skip = 0, byte_skip = 0;
};

const char* const kIgnoredFields[] = {"content", "min", "max", "old min", "oldmin", "old max", "oldmax",
                                      "labels", "units", "thicknesses", "axis mins", "axismins", "axis maxs",
                                      "axismaxs", "measurement frame", "sample units", "sampleunits", "number",
                                      "block size", "blocksize", "centers", "centerings"};

const ScalarType* nrrd_type(const std::string& t) {
    static const std::map<std::string, const char*> names = {
        {"signed char", "int8"}, {"int8", "int8"}, {"int8_t", "int8"},
        {"uchar", "uint8"}, {"unsigned char", "uint8"}, {"uint8", "uint8"}, {"uint8_t", "uint8"},
        {"short", "int16"}, {"short int", "int16"}, {"signed short", "int16"}, {"signed short int", "int16"},
        {"int16", "int16"}, {"int16_t", "int16"},
        {"ushort", "uint16"}, {"unsigned short", "uint16"}, {"unsigned short int", "uint16"},
        {"uint16", "uint16"}, {"uint16_t", "uint16"},
        {"int", "int32"}, {"signed int", "int32"}, {"int32", "int32"}, {"int32_t", "int32"},
        {"uint", "uint32"}, {"unsigned int", "uint32"}, {"uint32", "uint32"}, {"uint32_t", "uint32"},
        {"longlong", "int64"}, {"long long", "int64"}, {"long long int", "int64"},
        {"signed long long", "int64"}, {"signed long long int", "int64"}, {"int64", "int64"}, {"int64_t", "int64"},
        {"ulonglong", "uint64"}, {"unsigned long long", "uint64"}, {"unsigned long long int", "uint64"},
        {"uint64", "uint64"}, {"uint64_t", "uint64"},
        {"float", "float32"}, {"double", "float64"},
    };
    const auto it = names.find(t);
    return it == names.end() ? nullptr : scalar_type_by_name(it->second);
}

// "(a,b,c)" -> three finite numbers.
bool parse_vector(const std::string& text, double v[3]) {
    const std::string t = trim(text);
    if (t.size() < 2 || t.front() != '(' || t.back() != ')') return false;
    const std::string inner = t.substr(1, t.size() - 2);
    size_t start = 0;
    for (int k = 0; k < 3; ++k) {
        const size_t comma = inner.find(',', start);
        if ((k < 2) != (comma != std::string::npos)) return false;
        const std::string tok = trim(inner.substr(start, k < 2 ? comma - start : std::string::npos));
        if (!parse_double(tok, &v[k])) return false;
        start = comma + 1;
    }
    return true;
}

// Splits "(a,b,c) (d,e,f) ..." into the parenthesised groups.
std::vector<std::string> vector_groups(const std::string& s) {
    std::vector<std::string> out;
    size_t i = 0;
    while (i < s.size()) {
        while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        if (i >= s.size()) break;
        size_t j = i;
        if (s[i] == '(') {
            j = s.find(')', i);
            j = j == std::string::npos ? s.size() : j + 1;
        } else {
            while (j < s.size() && !std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        }
        out.push_back(s.substr(i, j - i));
        i = j;
    }
    return out;
}

bool field_value(Header* h, const std::string& field, const std::string& value, std::string* err) {
    const auto bad = [&](const std::string& why) { return fail(err, "field '" + field + "': " + why); };
    if (field == "type") {
        h->type_text = value;
        if (lower(value) == "block") return bad("type 'block' is not supported (scalar types only)");
        h->type = nrrd_type(lower(value));
        if (!h->type) return bad("unknown type '" + value + "'");
    } else if (field == "dimension") {
        if (!parse_int64(value, 1, 16, &h->dimension)) return bad("'" + value + "' is not a dimension 1..16");
        if (h->dimension != 3) return bad("dimension " + value + ": only 3-D images are supported");
    } else if (field == "sizes") {
        const std::vector<std::string> t = split_ws(value);
        if (t.size() != 3) return bad("expected 3 sizes, got " + std::to_string(t.size()));
        for (int a = 0; a < 3; ++a) {
            int64_t v;
            if (!parse_int64(t[size_t(a)], 1, 2147483647LL, &v)) return bad("'" + t[size_t(a)] + "' is not a size >= 1");
            h->sizes[a] = int(v);
        }
        h->have_sizes = true;
    } else if (field == "encoding") {
        const std::string e = lower(value);
        if (e == "raw") h->encoding = "raw";
        else if (e == "gzip" || e == "gz") h->encoding = "gzip";
        else if (e == "ascii" || e == "text" || e == "txt" || e == "hex" || e == "bzip2" || e == "bz2")
            return bad("encoding '" + value + "' is not supported (raw or gzip)");
        else return bad("unknown encoding '" + value + "'");
    } else if (field == "endian") {
        if (value == "little") h->big_endian = false;
        else if (value == "big") h->big_endian = true;
        else return bad("expected little or big, got '" + value + "'");
        h->have_endian = true;
    } else if (field == "space") {
        const std::string s = lower(value);
        if (s == "right-anterior-superior" || s == "ras") h->space = kRAS;
        else if (s == "left-anterior-superior" || s == "las") h->space = kLAS;
        else if (s == "left-posterior-superior" || s == "lps") h->space = kLPS;
        else return bad("space '" + value + "' is not supported (right-anterior-superior, "
                        "left-anterior-superior or left-posterior-superior: ffseg needs an anatomical frame)");
    } else if (field == "space dimension") {
        return bad("a space without an anatomical frame is not supported (give space: RAS, LAS or LPS)");
    } else if (field == "space directions") {
        const std::vector<std::string> g = vector_groups(value);
        if (g.size() != 3) return bad("expected 3 vectors, got " + std::to_string(g.size()));
        for (int a = 0; a < 3; ++a)
            if (g[size_t(a)] == "none" || !parse_vector(g[size_t(a)], h->dirs[a]))
                return bad("axis " + std::to_string(a) + ": '" + g[size_t(a)] + "' is not a vector (x,y,z) of finite numbers");
        h->have_dirs = true;
    } else if (field == "space origin") {
        if (!parse_vector(value, h->origin)) return bad("'" + value + "' is not a vector (x,y,z) of finite numbers");
        h->have_origin = true;
    } else if (field == "spacings") {
        const std::vector<std::string> t = split_ws(value);
        if (t.size() != 3) return bad("expected 3 spacings, got " + std::to_string(t.size()));
        for (int a = 0; a < 3; ++a)
            if (!parse_double(t[size_t(a)], &h->spacings[a]) || !(h->spacings[a] > 0))
                return bad("'" + t[size_t(a)] + "' is not a spacing > 0");
        h->have_spacings = true;
    } else if (field == "space units") {
        const std::vector<std::string> t = split_ws(value);
        if (t.size() != 3) return bad("expected 3 units, got " + std::to_string(t.size()));
        for (const std::string& u : t)
            if (u != "\"mm\"" && u != "mm") return bad("unit " + u + " is not mm");
    } else if (field == "kinds") {
        const std::vector<std::string> t = split_ws(value);
        if (t.size() != 3) return bad("expected 3 kinds, got " + std::to_string(t.size()));
        for (const std::string& k : t)
            if (k != "domain" && k != "space") return bad("kind '" + k + "': every axis must be spatial (domain or space)");
    } else if (field == "data file" || field == "datafile") {
        if (value == "LIST" || value.rfind("LIST ", 0) == 0 || value.find('%') != std::string::npos ||
            split_ws(value).size() != 1)
            return bad("'" + value + "': only one data file is supported (not LIST or a file-name pattern)");
        h->data_file = value;
    } else if (field == "line skip" || field == "lineskip") {
        if (!parse_int64(value, 0, 1 << 30, &h->line_skip)) return bad("'" + value + "' is not a count >= 0");
    } else if (field == "byte skip" || field == "byteskip") {
        if (!parse_int64(value, -1, int64_t(1) << 40, &h->byte_skip)) return bad("'" + value + "' is not -1 or a count >= 0");
    } else {
        for (const char* f : kIgnoredFields)
            if (field == f) return true;
        return fail(err, "unknown field '" + field + "'");
    }
    return true;
}

// Reads the header up to the blank line (or the end: a detached header).
bool parse_header(LineSource& lines, Header* h, bool* blank_line_seen, std::string* err) {
    std::string line;
    bool end = false;
    if (!lines.next(&line, &end, err)) return false;
    if (end || line.size() != 8 || line.compare(0, 7, "NRRD000") != 0 || line[7] < '1' || line[7] > '5')
        return fail(err, "not an NRRD file (the first line must be NRRD0001 .. NRRD0005)");
    h->version = line[7] - '0';
    std::map<std::string, bool> seen;
    *blank_line_seen = false;
    for (int n = 2;; ++n) {
        if (!lines.next(&line, &end, err)) return false;
        if (end) break;
        if (line.empty()) {
            *blank_line_seen = true;
            break;
        }
        if (line[0] == '#') continue;
        const size_t colon = line.find(": ");
        const size_t kv = line.find(":=");
        if (kv != std::string::npos && (colon == std::string::npos || kv < colon)) continue;  // key/value pair
        if (colon == std::string::npos || colon == 0)
            return fail(err, "line " + std::to_string(n) + ": expected 'field: value', got '" + line.substr(0, 80) + "'");
        const std::string field = line.substr(0, colon), value = trim(line.substr(colon + 2));
        if (seen[field]) return fail(err, "field '" + field + "' is given twice");
        seen[field] = true;
        if (!field_value(h, field, value, err)) return false;
    }
    for (const char* req : {"type", "dimension", "sizes", "encoding"})
        if (!seen[req]) return fail(err, std::string("field '") + req + "' is missing");
    if (h->type->file_bytes > 1 && !h->have_endian)
        return fail(err, "field 'endian' is missing (needed for " + h->type_text + " data)");
    if (h->space != kNoSpace && !h->have_dirs) return fail(err, "field 'space directions' is missing (space is given)");
    if (h->space == kNoSpace && (h->have_dirs || h->have_origin))
        return fail(err, std::string("field '") + (h->have_dirs ? "space directions" : "space origin") +
                             "' needs a 'space' field");
    if (h->have_dirs && h->have_spacings) return fail(err, "field 'spacings' contradicts 'space directions' (give one)");
    if (h->byte_skip == -1 && h->encoding != "raw") return fail(err, "field 'byte skip': -1 is only allowed with raw encoding");
    return true;
}

bool set_geometry(const Header& h, NiftiImage* out, std::string* err) {
    if (h.have_dirs) {
        double axis[3][3], origin[3];
        for (int a = 0; a < 3; ++a)
            for (int r = 0; r < 3; ++r) {
                // To LPS: RAS negates x and y, LAS negates y.
                const double sign = (h.space == kRAS && r < 2) || (h.space == kLAS && r == 1) ? -1.0 : 1.0;
                axis[a][r] = sign * h.dirs[a][r];
                if (a == 0) origin[r] = sign * h.origin[r];
            }
        return set_lps_geometry(axis, origin, out, "space directions", "field 'space directions'", err);
    }
    // spacings (or 1 mm): a diagonal affine in the tools' frame, like NIfTI's method 1.
    double axis[3][3] = {{-h.spacings[0], 0, 0}, {0, -h.spacings[1], 0}, {0, 0, h.spacings[2]}};
    const double origin[3] = {0, 0, 0};
    return set_lps_geometry(axis, origin, out, h.have_spacings ? "spacings" : "none (1 mm voxels)", "field 'spacings'",
                            err);
}

// Skips `lines` lines of src (the data file's line skip).
bool skip_lines(Source& src, int64_t lines, std::string* err) {
    uint8_t c;
    for (int64_t k = 0; k < lines;) {
        size_t got = 0;
        if (!src.read(&c, 1, &got, err)) return false;
        if (got == 0) return fail(err, "field 'line skip': the data ends before " + std::to_string(lines) + " lines");
        if (c == '\n') ++k;
    }
    return true;
}

bool skip_bytes(Source& src, int64_t n, std::string* err) {
    std::vector<uint8_t> buf(size_t(1) << 16);
    while (n > 0) {
        const size_t want = size_t(std::min<int64_t>(n, int64_t(buf.size())));
        size_t got = 0;
        if (!src.read(buf.data(), want, &got, err)) return false;
        if (got < want) return fail(err, "field 'byte skip': the data ends within the bytes to skip");
        n -= int64_t(got);
    }
    return true;
}

// The data from src (positioned at the data's first byte, line skip still to do).
bool read_body(Source& raw, const Header& h, const NiftiLimits& lim, NiftiImage* out, const std::string& what,
               std::string* err) {
    if (!skip_lines(raw, h.line_skip, err)) return false;
    Source* src = &raw;
    std::unique_ptr<GzipSource> gz;
    if (h.encoding == "gzip") {
        gz.reset(new GzipSource(raw));
        if (!gz->init(err)) return false;
        gz->set_limit(lim.max_bytes + uint64_t(h.byte_skip) + lim.slack_bytes);
        src = gz.get();
    }
    if (h.byte_skip > 0 && !skip_bytes(*src, h.byte_skip, err)) return false;
    if (!read_voxels(*src, *h.type, h.big_endian, h.sizes, lim, out, what, err)) return false;
    if (gz) {  // the stream must end properly (CRC checked) within the slack
        std::vector<uint8_t> rest(size_t(1) << 16);
        size_t got = 0;
        do {
            if (!gz->read(rest.data(), rest.size(), &got, err)) return false;
        } while (got == rest.size());
    }
    return set_geometry(h, out, err);
}

bool read_nrrd_file(const std::string& path, NiftiImage* out, std::string* err, const NiftiLimits& lim) {
    FILE* f = open_for_reading(path, err);
    if (!f) return false;
    std::unique_ptr<FILE, int (*)(FILE*)> guard(f, &std::fclose);
    Header h;
    bool blank = false;
    {
        FileLines lines(f);
        if (!parse_header(lines, &h, &blank, err)) return false;
    }
    if (h.data_file.empty()) {
        if (!blank) return fail(err, "no data: the header ends without a blank line and names no 'data file'");
        if (h.byte_skip == -1) {
            const uint64_t need = uint64_t(h.sizes[0]) * uint64_t(h.sizes[1]) * uint64_t(h.sizes[2]) *
                                  uint64_t(h.type->file_bytes);
            if (std::fseek(f, -long(need), SEEK_END) != 0) return fail(err, "field 'byte skip' -1: the file is shorter than its voxels");
        }
        FileSource fs(f);
        return read_body(fs, h, lim, out, "the attached data", err);
    }
    const std::string data_path = resolve_beside(path, h.data_file);
    FILE* d = open_for_reading(data_path, err);
    if (!d) return fail(err, "field 'data file': " + *err);
    std::unique_ptr<FILE, int (*)(FILE*)> dguard(d, &std::fclose);
    if (h.byte_skip == -1) {
        const uint64_t need = uint64_t(h.sizes[0]) * uint64_t(h.sizes[1]) * uint64_t(h.sizes[2]) *
                              uint64_t(h.type->file_bytes);
        if (h.line_skip > 0) return fail(err, "field 'byte skip' -1 cannot be combined with 'line skip'");
        if (std::fseek(d, -long(need), SEEK_END) != 0)
            return fail(err, "field 'byte skip' -1: data file '" + data_path + "' is shorter than its voxels");
    }
    FileSource ds(d);
    return read_body(ds, h, lim, out, "data file '" + data_path + "'", err);
}

}  // namespace

bool nrrd_read_file(const std::string& path, NiftiImage* out, std::string* err, const NiftiLimits& lim) {
    if (!out) return fail(err, "nrrd_read_file: null output");
    *out = NiftiImage();
    std::string e;
    if (!read_nrrd_file(path, out, &e, lim)) return fail(err, path + ": " + e);
    return true;
}

bool nrrd_read_memory(const uint8_t* data, size_t size, NiftiImage* out, std::string* err, const NiftiLimits& lim) {
    if (!out) return fail(err, "nrrd_read_memory: null output");
    if (!data && size > 0) return fail(err, "nrrd_read_memory: null data");
    *out = NiftiImage();
    Header h;
    bool blank = false;
    MemLines lines(data, size);
    if (!parse_header(lines, &h, &blank, err)) return false;
    if (!h.data_file.empty()) return fail(err, "field 'data file': a detached header cannot be read from memory");
    if (!blank) return fail(err, "no data: the header ends without a blank line");
    size_t at = lines.pos();
    if (h.byte_skip == -1) {
        const uint64_t need = uint64_t(h.sizes[0]) * uint64_t(h.sizes[1]) * uint64_t(h.sizes[2]) *
                              uint64_t(h.type->file_bytes);
        if (need > size - at) return fail(err, "field 'byte skip' -1: the data is shorter than its voxels");
        at = size - size_t(need);
    }
    MemSource ms(data + at, size - at);
    return read_body(ms, h, lim, out, "the attached data", err);
}

bool nrrd_write_file(const std::string& path, const NiftiImage& img, std::string* err) {
    if (!ends_with_ci(path, ".nrrd")) return fail(err, path + ": unsupported file name (use .nrrd)");
    const ScalarType* t = scalar_type_of_voxel_type(img.voxel_type);
    if (!t) return fail(err, fmt("%s: cannot write voxel_type %d", path.c_str(), img.voxel_type));
    for (int a = 0; a < 3; ++a)
        if (img.dims[a] < 1) return fail(err, path + ": cannot write: a dimension is < 1");
    if (img.data.size() != img.voxel_count() * uint64_t(t->out_bytes))
        return fail(err, path + ": cannot write: data size does not match dims and voxel type");
    double axis[3][3], origin[3];
    lps_geometry(img, axis, origin);
    std::string h = "NRRD0004\n# written by ffseg\n";
    const std::string tn = t->name;  // NRRD spells the float types "float" and "double"
    h += "type: " + (tn == "float32" ? std::string("float") : tn == "float64" ? std::string("double") : tn) +
         "\ndimension: 3\nspace: left-posterior-superior\n";
    h += fmt("sizes: %d %d %d\n", img.dims[0], img.dims[1], img.dims[2]);
    h += "space directions:";
    for (int a = 0; a < 3; ++a)
        h += " (" + exact(axis[a][0]) + "," + exact(axis[a][1]) + "," + exact(axis[a][2]) + ")";
    h += "\nkinds: domain domain domain\n";
    if (t->file_bytes > 1) h += std::string("endian: ") + (host_is_big_endian() ? "big" : "little") + "\n";
    h += "encoding: gzip\n";
    h += "space origin: (" + exact(origin[0]) + "," + exact(origin[1]) + "," + exact(origin[2]) + ")\n\n";
    return write_file_atomic(
        path, false,
        [&](Sink& sink, std::string* e) {
            if (!sink.write(reinterpret_cast<const uint8_t*>(h.data()), h.size(), e)) return false;
            GzipSink gz(sink);
            return gz.init(e) && gz.write(img.data.data(), img.data.size(), e) && gz.finish(e);
        },
        err);
}

}  // namespace ffseg_tools
