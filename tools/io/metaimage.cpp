// ffseg tools: strict MetaImage reader and writer (see metaimage.h).
#include "metaimage.h"

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

struct Header {
    const ScalarType* type = nullptr;
    std::string type_text;
    int dims[3] = {0, 0, 0};
    double spacing[3] = {1, 1, 1};
    double offset[3] = {0, 0, 0};
    double matrix[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    bool msb = false, compressed = false;
    int64_t compressed_size = -1, header_size = 0;
    std::string data_file;
    std::map<std::string, bool> seen;
};

const ScalarType* met_type(const std::string& t) {
    static const std::map<std::string, const char*> names = {
        {"MET_UCHAR", "uint8"},     {"MET_CHAR", "int8"},       {"MET_SHORT", "int16"},
        {"MET_USHORT", "uint16"},   {"MET_INT", "int32"},       {"MET_UINT", "uint32"},
        {"MET_LONG", "int32"},      {"MET_ULONG", "uint32"},    {"MET_LONG_LONG", "int64"},
        {"MET_ULONG_LONG", "uint64"}, {"MET_FLOAT", "float32"}, {"MET_DOUBLE", "float64"},
    };
    const auto it = names.find(t);
    return it == names.end() ? nullptr : scalar_type_by_name(it->second);
}

const char* met_name(int voxel_type) {
    switch (voxel_type) {
        case kNiftiVoxU8: return "MET_UCHAR";
        case kNiftiVoxI16: return "MET_SHORT";
        case kNiftiVoxU16: return "MET_USHORT";
        case kNiftiVoxI32: return "MET_INT";
        case kNiftiVoxF32: return "MET_FLOAT";
        case kNiftiVoxF64: return "MET_DOUBLE";
        default: return nullptr;
    }
}

bool numbers(const std::string& key, const std::string& v, size_t n, double* out, std::string* err) {
    const std::vector<std::string> t = split_ws(v);
    if (t.size() != n) return fail(err, fmt("field '%s': expected %zu numbers, got %zu", key.c_str(), n, t.size()));
    for (size_t k = 0; k < n; ++k)
        if (!parse_double(t[k], &out[k]))
            return fail(err, "field '" + key + "': '" + t[k] + "' is not a finite number");
    return true;
}

bool boolean(const std::string& key, const std::string& v, bool* out, std::string* err) {
    const std::string l = lower(v);
    if (l == "true") *out = true;
    else if (l == "false") *out = false;
    else return fail(err, "field '" + key + "': expected True or False, got '" + v + "'");
    return true;
}

// One "Key = Value" line; *last is set by ElementDataFile.
bool field(Header* h, const std::string& key, const std::string& v, bool* last, std::string* err) {
    // Aliases share one slot, so two of them are "given twice".
    std::string slot = key;
    if (key == "Origin" || key == "Position") slot = "Offset";
    if (key == "Rotation" || key == "Orientation") slot = "TransformMatrix";
    if (key == "ElementByteOrderMSB") slot = "BinaryDataByteOrderMSB";
    if (h->seen[slot]) return fail(err, "field '" + key + "' is given twice");
    h->seen[slot] = true;
    int64_t iv = 0;
    if (key == "ObjectType") {
        if (v != "Image") return fail(err, "field 'ObjectType': '" + v + "' is not Image");
    } else if (key == "NDims") {
        if (!parse_int64(v, 1, 16, &iv)) return fail(err, "field 'NDims': '" + v + "' is not a count");
        if (iv != 3) return fail(err, "field 'NDims': " + v + ": only 3-D images are supported");
    } else if (key == "DimSize") {
        const std::vector<std::string> t = split_ws(v);
        if (t.size() != 3) return fail(err, fmt("field 'DimSize': expected 3 sizes, got %zu", t.size()));
        for (int a = 0; a < 3; ++a) {
            if (!parse_int64(t[size_t(a)], 1, 2147483647LL, &iv))
                return fail(err, "field 'DimSize': '" + t[size_t(a)] + "' is not a size >= 1");
            h->dims[a] = int(iv);
        }
    } else if (key == "ElementType") {
        h->type_text = v;
        h->type = met_type(v);
        if (!h->type) return fail(err, "field 'ElementType': unsupported type '" + v + "'");
    } else if (key == "ElementNumberOfChannels") {
        if (!parse_int64(v, 1, 1 << 20, &iv) || iv != 1)
            return fail(err, "field 'ElementNumberOfChannels': '" + v + "': only one channel is supported");
    } else if (key == "ElementSpacing") {
        if (!numbers(key, v, 3, h->spacing, err)) return false;
        for (double s : h->spacing)
            if (!(s > 0)) return fail(err, "field 'ElementSpacing': every spacing must be > 0");
    } else if (slot == "Offset") {
        if (!numbers(key, v, 3, h->offset, err)) return false;
    } else if (slot == "TransformMatrix") {
        if (!numbers(key, v, 9, h->matrix, err)) return false;
    } else if (key == "CenterOfRotation") {
        double c[3];
        if (!numbers(key, v, 3, c, err)) return false;
    } else if (key == "BinaryData") {
        bool b = false;
        if (!boolean(key, v, &b, err)) return false;
        if (!b) return fail(err, "field 'BinaryData': ASCII data (False) is not supported");
    } else if (slot == "BinaryDataByteOrderMSB") {
        if (!boolean(key, v, &h->msb, err)) return false;
    } else if (key == "CompressedData") {
        if (!boolean(key, v, &h->compressed, err)) return false;
    } else if (key == "CompressedDataSize") {
        if (!parse_int64(v, 0, int64_t(1) << 50, &h->compressed_size))
            return fail(err, "field 'CompressedDataSize': '" + v + "' is not a byte count");
    } else if (key == "HeaderSize") {
        if (!parse_int64(v, -1, int64_t(1) << 40, &h->header_size))
            return fail(err, "field 'HeaderSize': '" + v + "' is not -1 or a byte count");
    } else if (key == "ElementDataFile") {
        if (v.empty()) return fail(err, "field 'ElementDataFile': empty");
        if (v == "LIST" || v.rfind("LIST ", 0) == 0 || v.find('%') != std::string::npos || split_ws(v).size() != 1)
            return fail(err, "field 'ElementDataFile': '" + v + "': only LOCAL or one data file is supported");
        h->data_file = v;
        *last = true;
    }
    return true;  // other fields: allowed by the format, skipped
}

bool parse_header(LineSource& lines, Header* h, std::string* err) {
    std::string line;
    bool end = false, last = false;
    const char* hint = " (field 'ElementDataFile', which ends the header, is missing before the data?)";
    for (int n = 1; !last; ++n) {
        if (!lines.next(&line, &end, err)) return fail(err, *err + (n > 1 ? hint : ""));
        if (end) return fail(err, n == 1 ? "empty file" : "field 'ElementDataFile' is missing (it ends the header)");
        const std::string t = trim(line);
        if (t.empty()) continue;
        const size_t eq = t.find('=');
        if (eq == std::string::npos || eq == 0) {
            if (n == 1) return fail(err, "not a MetaImage header (the first line is not 'Key = Value')");
            return fail(err, "line " + std::to_string(n) + ": expected 'Key = Value', got '" + t.substr(0, 80) + "'" + hint);
        }
        const std::string key = trim(t.substr(0, eq)), value = trim(t.substr(eq + 1));
        if (n == 1 && key != "ObjectType" && key != "NDims")
            return fail(err, "not a MetaImage header (it starts with '" + key.substr(0, 40) + "', not ObjectType or NDims)");
        if (!field(h, key, value, &last, err)) return false;
    }
    for (const char* req : {"NDims", "DimSize", "ElementType"})
        if (!h->seen[req]) return fail(err, std::string("field '") + req + "' is missing");
    if (h->header_size == -1 && h->compressed) return fail(err, "field 'HeaderSize': -1 is not allowed with CompressedData");
    return true;
}

bool read_body(Source& raw, const Header& h, const NiftiLimits& lim, NiftiImage* out, const std::string& what,
               std::string* err) {
    Source* src = &raw;
    std::unique_ptr<GzipSource> gz;
    std::unique_ptr<MemSource> packed;
    std::vector<uint8_t> compressed;
    if (h.compressed) {
        if (h.compressed_size >= 0) {
            // Exactly CompressedDataSize bytes: read them, then inflate those only.
            if (uint64_t(h.compressed_size) > lim.max_bytes) return fail(err, "field 'CompressedDataSize' exceeds the reader's bound");
            uint64_t left = 0;
            if (raw.remaining(&left) && left < uint64_t(h.compressed_size))
                return fail(err, fmt("field 'CompressedDataSize': %lld bytes, %s has %llu", (long long)h.compressed_size,
                                     what.c_str(), (unsigned long long)left));
            compressed.resize(size_t(h.compressed_size));
            size_t got = 0;
            if (!raw.read(compressed.data(), compressed.size(), &got, err)) return false;
            if (got < compressed.size())
                return fail(err, "field 'CompressedDataSize': " + what + " ends before that many bytes");
            packed.reset(new MemSource(compressed.data(), compressed.size()));
            gz.reset(new GzipSource(*packed));
        } else {
            gz.reset(new GzipSource(raw));
        }
        if (!gz->init(err)) return false;
        gz->set_limit(lim.max_bytes + lim.slack_bytes);
        src = gz.get();
    }
    if (!read_voxels(*src, *h.type, h.msb, h.dims, lim, out, what, err)) return false;
    double axis[3][3];
    for (int a = 0; a < 3; ++a)
        for (int r = 0; r < 3; ++r) axis[a][r] = h.matrix[3 * a + r] * h.spacing[a];
    return set_lps_geometry(axis, h.offset, out, "TransformMatrix", "fields 'TransformMatrix' / 'ElementSpacing'", err);
}

uint64_t data_bytes(const Header& h) {
    return uint64_t(h.dims[0]) * uint64_t(h.dims[1]) * uint64_t(h.dims[2]) * uint64_t(h.type->file_bytes);
}

bool read_mha_file(const std::string& path, NiftiImage* out, std::string* err, const NiftiLimits& lim) {
    FILE* f = open_for_reading(path, err);
    if (!f) return false;
    std::unique_ptr<FILE, int (*)(FILE*)> guard(f, &std::fclose);
    Header h;
    {
        FileLines lines(f);
        if (!parse_header(lines, &h, err)) return false;
    }
    if (h.data_file == "LOCAL") {
        FileSource fs(f);
        return read_body(fs, h, lim, out, "the local data", err);
    }
    const std::string data_path = resolve_beside(path, h.data_file);
    FILE* d = open_for_reading(data_path, err);
    if (!d) return fail(err, "field 'ElementDataFile': " + *err);
    std::unique_ptr<FILE, int (*)(FILE*)> dguard(d, &std::fclose);
    const bool ok = h.header_size == -1 ? std::fseek(d, -long(data_bytes(h)), SEEK_END) == 0
                                        : std::fseek(d, long(h.header_size), SEEK_SET) == 0;
    if (!ok) return fail(err, "field 'HeaderSize': data file '" + data_path + "' is too short");
    FileSource ds(d);
    return read_body(ds, h, lim, out, "data file '" + data_path + "'", err);
}

}  // namespace

bool metaimage_read_file(const std::string& path, NiftiImage* out, std::string* err, const NiftiLimits& lim) {
    if (!out) return fail(err, "metaimage_read_file: null output");
    *out = NiftiImage();
    std::string e;
    if (!read_mha_file(path, out, &e, lim)) return fail(err, path + ": " + e);
    return true;
}

bool metaimage_read_memory(const uint8_t* data, size_t size, NiftiImage* out, std::string* err,
                           const NiftiLimits& lim) {
    if (!out) return fail(err, "metaimage_read_memory: null output");
    if (!data && size > 0) return fail(err, "metaimage_read_memory: null data");
    *out = NiftiImage();
    Header h;
    MemLines lines(data, size);
    if (!parse_header(lines, &h, err)) return false;
    if (h.data_file != "LOCAL") return fail(err, "field 'ElementDataFile': a data file cannot be read from memory");
    MemSource ms(data + lines.pos(), size - lines.pos());
    return read_body(ms, h, lim, out, "the local data", err);
}

bool metaimage_write_file(const std::string& path, const NiftiImage& img, std::string* err) {
    if (!ends_with_ci(path, ".mha")) return fail(err, path + ": unsupported file name (use .mha)");
    const char* type = met_name(img.voxel_type);
    const ScalarType* t = scalar_type_of_voxel_type(img.voxel_type);
    if (!type || !t) return fail(err, fmt("%s: cannot write voxel_type %d", path.c_str(), img.voxel_type));
    for (int a = 0; a < 3; ++a)
        if (img.dims[a] < 1) return fail(err, path + ": cannot write: a dimension is < 1");
    if (img.data.size() != img.voxel_count() * uint64_t(t->out_bytes))
        return fail(err, path + ": cannot write: data size does not match dims and voxel type");
    std::vector<uint8_t> packed;
    {
        VecSink vs(&packed);
        GzipSink z(vs, true);
        std::string e;
        if (!z.init(&e) || !z.write(img.data.data(), img.data.size(), &e) || !z.finish(&e)) return fail(err, path + ": " + e);
    }
    double axis[3][3], origin[3];
    lps_geometry(img, axis, origin);
    std::string dirs, spacing;
    for (int a = 0; a < 3; ++a) {
        const double n = std::sqrt(axis[a][0] * axis[a][0] + axis[a][1] * axis[a][1] + axis[a][2] * axis[a][2]);
        if (!(n > 0) || !std::isfinite(n)) return fail(err, path + ": cannot write: a voxel axis has no length");
        for (int r = 0; r < 3; ++r) dirs += (dirs.empty() ? "" : " ") + exact(axis[a][r] / n);
        spacing += (a ? " " : "") + exact(n);
    }
    std::string h = "ObjectType = Image\nNDims = 3\nBinaryData = True\n";
    h += std::string("BinaryDataByteOrderMSB = ") + (host_is_big_endian() ? "True" : "False") + "\n";
    h += "CompressedData = True\nCompressedDataSize = " + std::to_string(packed.size()) + "\n";
    h += "TransformMatrix = " + dirs + "\n";
    h += "Offset = " + exact(origin[0]) + " " + exact(origin[1]) + " " + exact(origin[2]) + "\n";
    h += "ElementSpacing = " + spacing + "\n";
    h += fmt("DimSize = %d %d %d\n", img.dims[0], img.dims[1], img.dims[2]);
    h += std::string("ElementType = ") + type + "\nElementDataFile = LOCAL\n";
    return write_file_atomic(
        path, false,
        [&](Sink& sink, std::string* e) {
            return sink.write(reinterpret_cast<const uint8_t*>(h.data()), h.size(), e) &&
                   sink.write(packed.data(), packed.size(), e);
        },
        err);
}

}  // namespace ffseg_tools
