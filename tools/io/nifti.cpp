// ffseg tools: strict NIfTI-1 reader / writer.  See nifti.h for the policy.
//
// NIfTI-1 header layout used here (byte offsets, 348 bytes in total):
//     0 int   sizeof_hdr (348)          140 int    glmax, glmin
//    32 int   extents                   148 char   descrip[80]
//    36 short session_error             228 char   aux_file[24]
//    38 char  regular, 39 dim_info      252 short  qform_code, sform_code
//    40 short dim[8]                    256 float  quatern_b, _c, _d
//    56 float intent_p1, p2, p3         268 float  qoffset_x, _y, _z
//    68 short intent_code, datatype,    280 float  srow_x[4], srow_y[4],
//             bitpix, slice_start                  srow_z[4]
//    76 float pixdim[8]                 328 char   intent_name[16]
//   108 float vox_offset, scl_slope,    344 char   magic[4] ("n+1\0")
//             scl_inter                 348 char   extension[4] (single file)
//   120 short slice_end, 122 char slice_code, 123 char xyzt_units
//   124 float cal_max, cal_min, slice_duration, toffset
#include "nifti.h"

#include "byte_io.h"

// The voxel type codes must equal the engine's (include/ffseg.h).
#if defined(__has_include)
#if __has_include("ffseg.h")
#include "ffseg.h"
#endif
#endif
#ifdef FFSEG_U8
static_assert(ffseg_tools::kNiftiVoxU8 == FFSEG_U8 && ffseg_tools::kNiftiVoxI16 == FFSEG_I16 &&
                  ffseg_tools::kNiftiVoxU16 == FFSEG_U16 && ffseg_tools::kNiftiVoxI32 == FFSEG_I32 &&
                  ffseg_tools::kNiftiVoxF32 == FFSEG_F32 && ffseg_tools::kNiftiVoxF64 == FFSEG_F64,
              "NIfTI voxel type codes out of sync with ffseg.h");
#endif

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace ffseg_tools {
namespace {

using namespace io;

// Numeric fields of the header: {offset, element size, count}.  Used to turn
// a foreign-endian header into native order in one place.
struct FieldRun {
    int offset, size, count;
};
constexpr FieldRun kNumericFields[] = {
    {0, 4, 1},    // sizeof_hdr
    {32, 4, 1},   // extents
    {36, 2, 1},   // session_error
    {40, 2, 8},   // dim
    {56, 4, 3},   // intent_p1..3
    {68, 2, 4},   // intent_code, datatype, bitpix, slice_start
    {76, 4, 8},   // pixdim
    {108, 4, 3},  // vox_offset, scl_slope, scl_inter
    {120, 2, 1},  // slice_end
    {124, 4, 4},  // cal_max, cal_min, slice_duration, toffset
    {140, 4, 2},  // glmax, glmin
    {252, 2, 2},  // qform_code, sform_code
    {256, 4, 6},  // quatern_b..d, qoffset_x..z
    {280, 4, 12}, // srow_x, srow_y, srow_z
};

void swap_header_inplace(uint8_t* h) {
    for (const FieldRun& f : kNumericFields) swap_bytes_inplace(h + f.offset, size_t(f.size), size_t(f.count));
}

// Header fields we use, decoded from a native-order 348-byte header.
struct Hdr {
    int32_t sizeof_hdr;
    int16_t dim[8];
    int16_t intent_code, datatype, bitpix;
    float pixdim[8];
    float vox_offset, scl_slope, scl_inter;
    uint8_t xyzt_units;
    char descrip[81];
    int16_t qform_code, sform_code;
    float quatern[3];  // b, c, d
    float qoffset[3];
    float srow[12];
    char magic[4];
};

void decode_header(const uint8_t* h, Hdr* o) {
    o->sizeof_hdr = load<int32_t>(h + 0);
    for (int i = 0; i < 8; ++i) o->dim[i] = load<int16_t>(h + 40 + 2 * i);
    o->intent_code = load<int16_t>(h + 68);
    o->datatype = load<int16_t>(h + 70);
    o->bitpix = load<int16_t>(h + 72);
    for (int i = 0; i < 8; ++i) o->pixdim[i] = load<float>(h + 76 + 4 * i);
    o->vox_offset = load<float>(h + 108);
    o->scl_slope = load<float>(h + 112);
    o->scl_inter = load<float>(h + 116);
    o->xyzt_units = h[123];
    std::memcpy(o->descrip, h + 148, 80);
    o->descrip[80] = '\0';
    o->qform_code = load<int16_t>(h + 252);
    o->sform_code = load<int16_t>(h + 254);
    for (int i = 0; i < 3; ++i) o->quatern[i] = load<float>(h + 256 + 4 * i);
    for (int i = 0; i < 3; ++i) o->qoffset[i] = load<float>(h + 268 + 4 * i);
    for (int i = 0; i < 12; ++i) o->srow[i] = load<float>(h + 280 + 4 * i);
    std::memcpy(o->magic, h + 344, 4);
}

// ----------------------------------------------------------- datatype table

struct DtInfo {
    int datatype;
    int bitpix;       // required bitpix in the file
    int file_bytes;   // bytes per voxel in the file
    int voxel_type;   // engine type after conversion
    int out_bytes;    // bytes per voxel in NiftiImage::data
    const char* name;
};

constexpr DtInfo kDatatypes[] = {
    {kNiftiDtUint8, 8, 1, kNiftiVoxU8, 1, "uint8"},
    {kNiftiDtInt16, 16, 2, kNiftiVoxI16, 2, "int16"},
    {kNiftiDtInt32, 32, 4, kNiftiVoxI32, 4, "int32"},
    {kNiftiDtFloat32, 32, 4, kNiftiVoxF32, 4, "float32"},
    {kNiftiDtFloat64, 64, 8, kNiftiVoxF64, 8, "float64"},
    {kNiftiDtUint16, 16, 2, kNiftiVoxU16, 2, "uint16"},
    // Widened on read:
    {kNiftiDtInt8, 8, 1, kNiftiVoxI16, 2, "int8"},
    {kNiftiDtUint32, 32, 4, kNiftiVoxF64, 8, "uint32"},
    {kNiftiDtInt64, 64, 8, kNiftiVoxF64, 8, "int64"},   // exact up to 2^53
    {kNiftiDtUint64, 64, 8, kNiftiVoxF64, 8, "uint64"}, // exact up to 2^53
};

const DtInfo* find_datatype(int dt) {
    for (const DtInfo& d : kDatatypes)
        if (d.datatype == dt) return &d;
    return nullptr;
}

// Datatypes defined by NIfTI-1 that we deliberately refuse.
const char* known_unsupported_datatype(int dt) {
    switch (dt) {
        case 1: return "binary";
        case 32: return "complex64";
        case 128: return "rgb24";
        case 1536: return "float128";
        case 1792: return "complex128";
        case 2048: return "complex256";
        case 2304: return "rgba32";
        default: return nullptr;
    }
}

// ----------------------------------------------------------------- geometry

// 3x3 determinant of the upper-left block of a row-major 4x4.
double det3(const double* m) {
    return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
           m[2] * (m[4] * m[9] - m[5] * m[8]);
}
double column_norm(const double* m, int c) {
    return std::sqrt(m[c] * m[c] + m[4 + c] * m[4 + c] + m[8 + c] * m[8 + c]);
}

void set_identity(double* m) {
    for (int i = 0; i < 16; ++i) m[i] = (i % 5 == 0) ? 1.0 : 0.0;
}

// Quaternion (b, c, d; a >= 0 implied) + voxel sizes + qfac + offset -> 4x4.
void qform_to_matrix(double b, double c, double d, double dx, double dy, double dz, double qfac,
                     const double* off, double* m) {
    double s = b * b + c * c + d * d;
    double a;
    if (s > 1.0) {  // within tolerance (checked by the caller): a = 0
        const double k = 1.0 / std::sqrt(s);
        b *= k;
        c *= k;
        d *= k;
        a = 0.0;
    } else {
        a = std::sqrt(1.0 - s);
    }
    const double R[9] = {a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),
                         2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
                         2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b};
    const double scale[3] = {dx, dy, dz * qfac};
    for (int r = 0; r < 3; ++r) {
        for (int col = 0; col < 3; ++col) m[4 * r + col] = R[3 * r + col] * scale[col];
        m[4 * r + 3] = off[r];
    }
    m[12] = m[13] = m[14] = 0.0;
    m[15] = 1.0;
}

constexpr double kQuatEps = 1e-5;  // tolerance on b^2+c^2+d^2 <= 1

// Validates every transform present in the header (code > 0) and fills the
// geometry fields of *img (index_to_world, which_affine, spacing).
bool header_geometry(const Hdr& h, NiftiImage* img, std::string* err) {
    // qform_code / sform_code: 0..4 are NIfTI-1 (unknown, scanner, aligned,
    // talairach, mni152); 5 (template other) was added later and is accepted.
    if (h.qform_code < 0 || h.qform_code > 5)
        return fail(err, fmt("qform_code %d out of range 0..5", h.qform_code));
    if (h.sform_code < 0 || h.sform_code > 5)
        return fail(err, fmt("sform_code %d out of range 0..5", h.sform_code));

    // pixdim[1..3] must be finite whatever transform is used.
    for (int i = 1; i <= 3; ++i)
        if (!std::isfinite(h.pixdim[i])) return fail(err, fmt("pixdim[%d] is not finite", i));

    // Voxel sizes for the qform / pixdim methods.  Axes beyond dim[0] are
    // singleton axes the spec says to ignore: a non-positive size there is
    // replaced by 1.  For real axes the size must be > 0 (checked below, only
    // if one of those methods is actually used).
    double vox[3];
    for (int i = 0; i < 3; ++i) {
        vox[i] = h.pixdim[i + 1];
        if (i + 1 > h.dim[0] && !(vox[i] > 0)) vox[i] = 1.0;
    }

    double qmat[16];
    if (h.qform_code > 0) {
        for (int i = 0; i < 3; ++i)
            if (!std::isfinite(h.quatern[i])) return fail(err, "qform quaternion (quatern_b/c/d) is not finite");
        for (int i = 0; i < 3; ++i)
            if (!std::isfinite(h.qoffset[i])) return fail(err, "qform offset (qoffset_x/y/z) is not finite");
        if (!std::isfinite(h.pixdim[0])) return fail(err, "pixdim[0] (qfac) is not finite");
        const double b = h.quatern[0], c = h.quatern[1], d = h.quatern[2];
        const double s = b * b + c * c + d * d;
        if (s > 1.0 + kQuatEps)
            return fail(err, fmt("qform quaternion is not a unit quaternion (b^2+c^2+d^2 = %g > 1)", s));
        // qfac: pixdim[0]; the spec says -1 or 1 with 0 meaning 1.  We use
        // its sign (negative -> -1, zero or positive -> +1).
        const double qfac = h.pixdim[0] < 0 ? -1.0 : 1.0;
        const double off[3] = {h.qoffset[0], h.qoffset[1], h.qoffset[2]};
        qform_to_matrix(b, c, d, vox[0], vox[1], vox[2], qfac, off, qmat);
    }

    double smat[16];
    if (h.sform_code > 0) {
        static const char kAxis[3] = {'x', 'y', 'z'};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                if (!std::isfinite(h.srow[4 * r + c])) return fail(err, fmt("sform row srow_%c is not finite", kAxis[r]));
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) smat[4 * r + c] = h.srow[4 * r + c];
        smat[12] = smat[13] = smat[14] = 0.0;
        smat[15] = 1.0;
        // Singular: a zero column, or a determinant negligible relative to
        // the product of the column lengths (columns nearly dependent).
        const double n0 = column_norm(smat, 0), n1 = column_norm(smat, 1), n2 = column_norm(smat, 2);
        const double det = det3(smat);
        if (!(n0 > 0 && n1 > 0 && n2 > 0) || !(std::fabs(det) > 1e-6 * n0 * n1 * n2))
            return fail(err, fmt("sform is singular (det %g)", det));
    }

    if (h.sform_code > 0) {
        std::memcpy(img->index_to_world, smat, sizeof smat);
        img->which_affine = "sform";
        for (int i = 0; i < 3; ++i) img->spacing[i] = column_norm(smat, i);
        return true;
    }
    // qform or pixdim: the voxel sizes are used, they must be positive.
    for (int i = 0; i < 3; ++i)
        if (!(vox[i] > 0))
            return fail(err, fmt("pixdim[%d] = %g must be > 0 (voxel size used by the %s affine)", i + 1, vox[i],
                                 h.qform_code > 0 ? "qform" : "pixdim"));
    for (int i = 0; i < 3; ++i) img->spacing[i] = vox[i];
    if (h.qform_code > 0) {
        std::memcpy(img->index_to_world, qmat, sizeof qmat);
        img->which_affine = "qform";
        return true;
    }
    set_identity(img->index_to_world);
    for (int i = 0; i < 3; ++i) img->index_to_world[5 * i] = vox[i];
    img->which_affine = "pixdim";
    return true;
}

// ---------------------------------------------------------------- the reader

bool read_nifti(Source& raw, bool gzip, const NiftiLimits& lim, NiftiImage* out, std::string* err) {
    *out = NiftiImage();
    std::unique_ptr<GzipSource> gz;
    Source* src = &raw;
    if (gzip) {
        gz.reset(new GzipSource(raw));
        if (!gz->init(err)) return false;
        gz->set_limit(lim.max_bytes);
        src = gz.get();
    }
    const char* what = gzip ? " (after gzip decompression)" : "";

    uint8_t h[kNiftiHeaderSize];
    size_t got = 0;
    if (!src->read(h, sizeof h, &got, err)) return false;
    if (got == 0) return fail(err, fmt("empty file%s", what));

    // Byte order from sizeof_hdr.
    bool swap = false;
    if (got >= 4) {
        const int32_t s = load<int32_t>(h);
        int32_t ss = s;
        swap_bytes_inplace(reinterpret_cast<uint8_t*>(&ss), 4, 1);
        if (s == 540 || ss == 540) return fail(err, "NIfTI-2 file (sizeof_hdr 540) is not supported; only NIfTI-1");
        if (s == 348) {
            swap = false;
        } else if (ss == 348) {
            swap = true;
        } else {
            return fail(err, fmt("bad sizeof_hdr %d (expected 348 for NIfTI-1)", s));
        }
    }
    if (got < sizeof h)
        return fail(err, fmt("file too short for a NIfTI-1 header: %zu bytes%s, need 348", got, what));
    if (swap) swap_header_inplace(h);
    Hdr hd;
    decode_header(h, &hd);

    // Magic.
    if (std::memcmp(hd.magic, "ni1\0", 4) == 0)
        return fail(err, "magic \"ni1\": two-file NIfTI-1 (.hdr/.img pair) is not supported; use a single .nii");
    if (std::memcmp(hd.magic, "n+2\0", 4) == 0 || std::memcmp(hd.magic, "ni2\0", 4) == 0)
        return fail(err, "NIfTI-2 magic: NIfTI-2 is not supported; only NIfTI-1");
    if (std::memcmp(hd.magic, "n+1\0", 4) != 0)
        return fail(err, "bad magic (expected \"n+1\\0\"; ANALYZE 7.5 and other formats are not supported)");

    // Dimensions.
    const int ndim = hd.dim[0];
    if (ndim < 1 || ndim > 7) return fail(err, fmt("dim[0] = %d out of range 1..7", ndim));
    for (int i = 1; i <= ndim; ++i)
        if (hd.dim[i] <= 0) return fail(err, fmt("dim[%d] = %d must be positive", i, hd.dim[i]));
    // Product of all dimensions, overflow-checked (7 shorts can exceed 2^64).
    uint64_t nvox_all = 1;
    for (int i = 1; i <= ndim; ++i)
        if (__builtin_mul_overflow(nvox_all, uint64_t(hd.dim[i]), &nvox_all))
            return fail(err, "voxel count (product of dims) overflows 64 bits");
    for (int i = 4; i <= ndim; ++i)
        if (hd.dim[i] != 1)
            return fail(err, fmt("dim[%d] = %d: only 3D images are supported (dims 4..7 must be 1)", i, hd.dim[i]));

    // Datatype and bitpix.
    const DtInfo* dt = find_datatype(hd.datatype);
    if (!dt) {
        if (const char* name = known_unsupported_datatype(hd.datatype))
            return fail(err, fmt("datatype %d (%s) is not supported", hd.datatype, name));
        return fail(err, fmt("unknown datatype %d", hd.datatype));
    }
    if (hd.bitpix != dt->bitpix)
        return fail(err, fmt("bitpix %d does not match datatype %d (%s needs bitpix %d)", hd.bitpix, hd.datatype,
                             dt->name, dt->bitpix));

    // vox_offset: a float in the header; must be an integer >= 352 for a
    // single-file NIfTI-1 (348 header bytes + 4 extension-flag bytes).  The
    // spec asks for a multiple of 16; that is not enforced.
    const double vo = hd.vox_offset;
    if (!std::isfinite(vo)) return fail(err, "vox_offset is not finite");
    if (vo < 352) return fail(err, fmt("vox_offset %g is below 352 (single-file NIfTI-1 minimum)", vo));
    if (vo != std::floor(vo)) return fail(err, fmt("vox_offset %g is not an integer", vo));
    if (vo > double(lim.max_bytes))
        return fail(err, fmt("vox_offset %g exceeds the limit of %llu bytes (NiftiLimits::max_bytes)", vo,
                             (unsigned long long)lim.max_bytes));
    const uint64_t vox_offset = uint64_t(vo);

    uint64_t file_bytes = 0, out_bytes = 0, needed = 0;
    if (__builtin_mul_overflow(nvox_all, uint64_t(dt->file_bytes), &file_bytes) ||
        __builtin_mul_overflow(nvox_all, uint64_t(dt->out_bytes), &out_bytes) ||
        __builtin_add_overflow(file_bytes, vox_offset, &needed))
        return fail(err, "data size overflows 64 bits");
    if (needed > lim.max_bytes || out_bytes > lim.max_bytes)
        return fail(err, fmt("image needs %llu bytes, more than the limit of %llu (NiftiLimits::max_bytes)",
                             (unsigned long long)std::max(needed, out_bytes), (unsigned long long)lim.max_bytes));
    if (out_bytes > uint64_t(std::numeric_limits<size_t>::max()) / 2)
        return fail(err, "image too large for this platform");

    // Scaling: a zero slope means "no scaling" (per the standard); non-finite
    // values are refused even when the slope is zero.
    if (!std::isfinite(hd.scl_slope)) return fail(err, "scl_slope is not finite");
    if (!std::isfinite(hd.scl_inter)) return fail(err, "scl_inter is not finite");

    // Geometry (validates qform / sform / pixdim).
    if (!header_geometry(hd, out, err)) return false;

    // ---- header accepted: fill the metadata
    for (int i = 0; i < 3; ++i) out->dims[i] = (i + 1 <= ndim) ? hd.dim[i + 1] : 1;
    out->voxel_type = dt->voxel_type;
    out->bytes_per_voxel = dt->out_bytes;
    out->datatype = hd.datatype;
    for (int i = 0; i < 8; ++i) out->pixdim[i] = hd.pixdim[i];
    if (hd.scl_slope == 0.0f) {
        out->scl_slope = 1.0;
        out->scl_inter = 0.0;
    } else {
        out->scl_slope = hd.scl_slope;
        out->scl_inter = hd.scl_inter;
    }
    out->sform_code = hd.sform_code;
    out->qform_code = hd.qform_code;
    out->intent_code = hd.intent_code;
    out->xyzt_units = hd.xyzt_units;
    out->descrip.assign(hd.descrip, strnlen(hd.descrip, 80));
    out->raw_header.assign(h, h + sizeof h);

    // Bound the decompressed size: header-implied size plus a small slack.
    if (gz) {
        uint64_t bound = needed;
        if (__builtin_add_overflow(needed, lim.slack_bytes, &bound)) bound = std::numeric_limits<uint64_t>::max();
        gz->set_limit(std::min<uint64_t>(bound, lim.max_bytes));
    }

    // Known-size input: refuse a short file before allocating anything.
    uint64_t avail = 0;
    const bool size_known = src->remaining(&avail);
    if (size_known) {
        const uint64_t after_hdr = vox_offset - sizeof h;
        if (avail < after_hdr)
            return fail(err, fmt("vox_offset %llu is past the end of the file (only %llu bytes)",
                                 (unsigned long long)vox_offset, (unsigned long long)(avail + sizeof h)));
        if (avail - after_hdr < file_bytes)
            return fail(err, fmt("voxel data truncated: need %llu bytes after vox_offset, got %llu",
                                 (unsigned long long)file_bytes, (unsigned long long)(avail - after_hdr)));
    }

    // ---- skip extensions up to vox_offset
    {
        uint8_t scratch[4096];
        uint64_t left = vox_offset - sizeof h;
        while (left > 0) {
            const size_t want = size_t(std::min<uint64_t>(left, sizeof scratch));
            if (!src->read(scratch, want, &got, err)) return false;
            left -= got;
            if (got < want)
                return fail(err, fmt("vox_offset %llu is past the end of the file%s (only %llu bytes)",
                                     (unsigned long long)vox_offset, what,
                                     (unsigned long long)(vox_offset - left)));
        }
    }

    // ---- voxel data: read into the front of the output buffer, then
    // byte-swap and widen in place (backwards, so nothing is overwritten
    // before it is read).
    // When the input size is unknown (gzip, pipes) the buffer grows by
    // doubling as data actually arrives, so a lying header cannot make us
    // allocate more than ~2x what the stream really contains. It starts at
    // 1 MB, or at kPackedRatio times the compressed bytes left when those
    // are known: CT and MR volumes deflate 2-5 to 1, so a whole volume
    // usually lands in its first buffer (the 1 mm CT of 75 MB grew six times
    // from 1 MB, each growth zero-filling and copying: a third of its read
    // time), and a lying header still gets at most that before data arrives.
    {
        constexpr uint64_t kPackedRatio = 4;
        uint64_t have = 0, packed = 0, start = uint64_t(1) << 20;
        if (!size_known && src->compressed_remaining(&packed)) start = std::max(start, kPackedRatio * packed);
        uint64_t cap = size_known ? file_bytes : std::min<uint64_t>(file_bytes, start);
        out->data.reserve(size_t(size_known ? out_bytes : cap));
        out->data.resize(size_t(cap));
        while (have < file_bytes) {
            if (have == cap) {
                cap = std::min<uint64_t>(file_bytes, cap * 2);
                out->data.resize(size_t(cap));
            }
            const size_t want = size_t(std::min<uint64_t>(cap - have, uint64_t(1) << 30));
            if (!src->read(out->data.data() + have, want, &got, err)) return false;
            have += got;
            if (got < want)
                return fail(err, fmt("voxel data truncated: need %llu bytes after vox_offset, got %llu",
                                     (unsigned long long)file_bytes, (unsigned long long)have));
        }
        out->data.resize(size_t(out_bytes));
    }

    // ---- gzip: the stream must end (CRC verified) within the slack
    if (gz) {
        uint8_t scratch[4096];
        for (;;) {
            if (!src->read(scratch, sizeof scratch, &got, err)) return false;
            if (got < sizeof scratch) break;
        }
    }
    // Uncompressed input: bytes after the voxel data are ignored (they cost
    // no memory; some writers pad files).

    const size_t n = size_t(nvox_all);
    uint8_t* p = out->data.data();
    if (swap) swap_bytes_inplace(p, size_t(dt->file_bytes), n);
    switch (hd.datatype) {
        case kNiftiDtInt8:
            for (size_t i = n; i-- > 0;) store<int16_t>(p + 2 * i, int16_t(load<int8_t>(p + i)));
            break;
        case kNiftiDtUint32:
            for (size_t i = n; i-- > 0;) store<double>(p + 8 * i, double(load<uint32_t>(p + 4 * i)));
            break;
        case kNiftiDtInt64:
            for (size_t i = 0; i < n; ++i) store<double>(p + 8 * i, double(load<int64_t>(p + 8 * i)));
            break;
        case kNiftiDtUint64:
            for (size_t i = 0; i < n; ++i) store<double>(p + 8 * i, double(load<uint64_t>(p + 8 * i)));
            break;
        default:
            break;
    }
    return true;
}

// ------------------------------------------------------------------ writer

// Nearest rotation to a 3x3 (row-major) by the Newton polar iteration
// X <- (X + X^-T) / 2.  Input must be non-singular.
void nearest_rotation(double* X) {
    for (int it = 0; it < 100; ++it) {
        const double a = X[0], b = X[1], c = X[2], d = X[3], e = X[4], f = X[5], g = X[6], h = X[7], i = X[8];
        const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
        if (det == 0) return;
        // inverse transpose = cofactor matrix / det
        const double C[9] = {(e * i - f * h) / det, -(d * i - f * g) / det, (d * h - e * g) / det,
                             -(b * i - c * h) / det, (a * i - c * g) / det, -(a * h - b * g) / det,
                             (b * f - c * e) / det, -(a * f - c * d) / det, (a * e - b * d) / det};
        double change = 0;
        for (int k = 0; k < 9; ++k) {
            const double nx = 0.5 * (X[k] + C[k]);
            change = std::max(change, std::fabs(nx - X[k]));
            X[k] = nx;
        }
        if (change < 1e-15) return;
    }
}

struct QForm {
    double b, c, d, dx, dy, dz, qfac, off[3];
};

// Decompose a 4x4 (row-major) into a NIfTI qform.  Returns false if singular.
bool matrix_to_qform(const double* m, QForm* q) {
    double n[3];
    for (int c = 0; c < 3; ++c) n[c] = column_norm(m, c);
    if (!(n[0] > 0 && n[1] > 0 && n[2] > 0)) return false;
    double R[9];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R[3 * r + c] = m[4 * r + c] / n[c];
    const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                       R[2] * (R[3] * R[7] - R[4] * R[6]);
    if (!(std::fabs(det) > 1e-6)) return false;
    q->qfac = 1.0;
    if (det < 0) {  // reflection: flip the third axis, qfac = -1
        q->qfac = -1.0;
        for (int r = 0; r < 3; ++r) R[3 * r + 2] = -R[3 * r + 2];
    }
    nearest_rotation(R);
    double a, b, c, d;
    const double tr = R[0] + R[4] + R[8];
    if (tr > 0) {
        a = 0.5 * std::sqrt(1.0 + tr);
        b = (R[7] - R[5]) / (4 * a);
        c = (R[2] - R[6]) / (4 * a);
        d = (R[3] - R[1]) / (4 * a);
    } else if (R[0] >= R[4] && R[0] >= R[8]) {
        b = 0.5 * std::sqrt(std::max(0.0, 1.0 + R[0] - R[4] - R[8]));
        a = (R[7] - R[5]) / (4 * b);
        c = (R[1] + R[3]) / (4 * b);
        d = (R[2] + R[6]) / (4 * b);
    } else if (R[4] >= R[8]) {
        c = 0.5 * std::sqrt(std::max(0.0, 1.0 + R[4] - R[0] - R[8]));
        a = (R[2] - R[6]) / (4 * c);
        b = (R[1] + R[3]) / (4 * c);
        d = (R[5] + R[7]) / (4 * c);
    } else {
        d = 0.5 * std::sqrt(std::max(0.0, 1.0 + R[8] - R[0] - R[4]));
        a = (R[3] - R[1]) / (4 * d);
        b = (R[2] + R[6]) / (4 * d);
        c = (R[5] + R[7]) / (4 * d);
    }
    if (a < 0) {
        b = -b;
        c = -c;
        d = -d;
    }
    q->b = b;
    q->c = c;
    q->d = d;
    q->dx = n[0];
    q->dy = n[1];
    q->dz = n[2];
    for (int r = 0; r < 3; ++r) q->off[r] = m[4 * r + 3];
    return true;
}

bool build_header(const NiftiImage& img, uint8_t* h, std::string* err) {
    std::memset(h, 0, 352);
    const int dt = nifti_datatype_for_voxel_type(img.voxel_type);
    const int bpv = nifti_voxel_type_size(img.voxel_type);
    if (dt == 0) return fail(err, fmt("cannot write: unknown voxel_type %d", img.voxel_type));
    if (img.bytes_per_voxel != 0 && img.bytes_per_voxel != bpv)
        return fail(err, fmt("cannot write: bytes_per_voxel %d does not match voxel_type %d", img.bytes_per_voxel,
                             img.voxel_type));
    for (int i = 0; i < 3; ++i)
        if (img.dims[i] < 1 || img.dims[i] > 32767)
            return fail(err, fmt("cannot write: dims[%d] = %d out of range 1..32767", i, img.dims[i]));
    const uint64_t need = img.voxel_count() * uint64_t(bpv);
    if (img.data.size() != need)
        return fail(err, fmt("cannot write: data has %zu bytes, dims x bytes_per_voxel = %llu", img.data.size(),
                             (unsigned long long)need));
    const double* m = img.index_to_world;
    for (int k = 0; k < 16; ++k)
        if (!std::isfinite(m[k])) return fail(err, "cannot write: index_to_world is not finite");
    if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1)
        return fail(err, "cannot write: index_to_world last row must be 0 0 0 1");
    if (!std::isfinite(img.scl_slope) || !std::isfinite(img.scl_inter))
        return fail(err, "cannot write: scl_slope / scl_inter not finite");
    QForm q;
    if (!matrix_to_qform(m, &q)) return fail(err, "cannot write: index_to_world is singular");
    {
        // Also refuse what the reader would refuse as a singular sform.
        const double n0 = column_norm(m, 0), n1 = column_norm(m, 1), n2 = column_norm(m, 2);
        if (!(std::fabs(det3(m)) > 1e-6 * n0 * n1 * n2)) return fail(err, "cannot write: index_to_world is singular");
    }

    int scode = img.sform_code > 0 ? img.sform_code : (img.qform_code > 0 ? img.qform_code : 2);
    int qcode = img.qform_code > 0 ? img.qform_code : scode;
    if (scode > 5) scode = 2;
    if (qcode > 5) qcode = 2;

    store<int32_t>(h + 0, 348);
    h[38] = 'r';
    const int16_t dim[8] = {3, int16_t(img.dims[0]), int16_t(img.dims[1]), int16_t(img.dims[2]), 1, 1, 1, 1};
    for (int i = 0; i < 8; ++i) store<int16_t>(h + 40 + 2 * i, dim[i]);
    store<int16_t>(h + 68, int16_t(img.intent_code));
    store<int16_t>(h + 70, int16_t(dt));
    store<int16_t>(h + 72, int16_t(8 * bpv));
    const float pix[8] = {float(q.qfac), float(q.dx), float(q.dy), float(q.dz), 0, 0, 0, 0};
    for (int i = 0; i < 8; ++i) store<float>(h + 76 + 4 * i, pix[i]);
    store<float>(h + 108, 352.0f);
    store<float>(h + 112, float(img.scl_slope));
    store<float>(h + 116, float(img.scl_inter));
    h[123] = uint8_t(img.xyzt_units != 0 ? img.xyzt_units : 2 /* NIFTI_UNITS_MM */);
    const size_t dl = std::min<size_t>(img.descrip.size(), 79);
    std::memcpy(h + 148, img.descrip.data(), dl);
    store<int16_t>(h + 252, int16_t(qcode));
    store<int16_t>(h + 254, int16_t(scode));
    const float qv[6] = {float(q.b), float(q.c), float(q.d), float(q.off[0]), float(q.off[1]), float(q.off[2])};
    for (int i = 0; i < 6; ++i) store<float>(h + 256 + 4 * i, qv[i]);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) store<float>(h + 280 + 4 * (4 * r + c), float(m[4 * r + c]));
    std::memcpy(h + 344, "n+1\0", 4);
    // h[348..351]: extension flag, all zero (no extensions).
    return true;
}

bool encode_to(const NiftiImage& img, bool gzip, Sink& sink, std::string* err) {
    uint8_t h[352];
    if (!build_header(img, h, err)) return false;
    std::unique_ptr<GzipSink> gz;
    Sink* s = &sink;
    if (gzip) {
        gz.reset(new GzipSink(sink));
        if (!gz->init(err)) return false;
        s = gz.get();
    }
    if (!s->write(h, sizeof h, err)) return false;
    if (!img.data.empty() && !s->write(img.data.data(), img.data.size(), err)) return false;
    return s->finish(err);
}

}  // namespace

// ================================================================ public API

int nifti_voxel_type_size(int voxel_type) {
    switch (voxel_type) {
        case kNiftiVoxU8: return 1;
        case kNiftiVoxI16: return 2;
        case kNiftiVoxU16: return 2;
        case kNiftiVoxI32: return 4;
        case kNiftiVoxF32: return 4;
        case kNiftiVoxF64: return 8;
        default: return 0;
    }
}

int nifti_datatype_for_voxel_type(int voxel_type) {
    switch (voxel_type) {
        case kNiftiVoxU8: return kNiftiDtUint8;
        case kNiftiVoxI16: return kNiftiDtInt16;
        case kNiftiVoxU16: return kNiftiDtUint16;
        case kNiftiVoxI32: return kNiftiDtInt32;
        case kNiftiVoxF32: return kNiftiDtFloat32;
        case kNiftiVoxF64: return kNiftiDtFloat64;
        default: return 0;
    }
}

bool nifti_read_memory(const uint8_t* data, size_t size, NiftiImage* out, std::string* err,
                       const NiftiLimits& lim) {
    if (!out) return fail(err, "nifti_read_memory: null output");
    if (!data && size > 0) return fail(err, "nifti_read_memory: null data");
    MemSource ms(data, size);
    const bool gzip = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
    return read_nifti(ms, gzip, lim, out, err);
}

bool nifti_read_file(const std::string& path, NiftiImage* out, std::string* err, const NiftiLimits& lim) {
    if (!out) return fail(err, "nifti_read_file: null output");
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return fail(err, fmt("cannot open '%s': %s", path.c_str(), std::strerror(errno)));
    std::unique_ptr<FILE, int (*)(FILE*)> guard(f, &std::fclose);
    FileSource fs(f);
    uint8_t magic[2];
    size_t got = 0;
    std::string e;
    bool ok = fs.read(magic, 2, &got, &e);
    if (ok) {
        fs.push_prefix(magic, got);
        const bool gzip = got == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
        ok = read_nifti(fs, gzip, lim, out, &e);
    }
    if (!ok) return fail(err, path + ": " + e);
    return true;
}

bool nifti_encode(const NiftiImage& img, bool gzip, std::vector<uint8_t>* out, std::string* err) {
    if (!out) return fail(err, "nifti_encode: null output");
    out->clear();
    VecSink vs(out);
    return encode_to(img, gzip, vs, err);
}

bool nifti_write_file(const std::string& path, const NiftiImage& img, std::string* err) {
    bool gzip;
    if (ends_with_ci(path, ".nii.gz")) {
        gzip = true;
    } else if (ends_with_ci(path, ".nii")) {
        gzip = false;
    } else {
        return fail(err, path + ": unsupported file name (use .nii or .nii.gz)");
    }
    // Validate before creating anything.
    {
        uint8_t h[352];
        std::string e;
        if (!build_header(img, h, &e)) return fail(err, path + ": " + e);
    }
    return write_file_atomic(
        path, false, [&](Sink& sink, std::string* e) { return encode_to(img, gzip, sink, e); }, err);
}

NiftiImage nifti_make_label_image(const NiftiImage& ref, int voxel_type) {
    NiftiImage o;
    for (int i = 0; i < 3; ++i) o.dims[i] = ref.dims[i];
    std::memcpy(o.index_to_world, ref.index_to_world, sizeof o.index_to_world);
    o.which_affine = ref.which_affine;
    std::memcpy(o.pixdim, ref.pixdim, sizeof o.pixdim);
    std::memcpy(o.spacing, ref.spacing, sizeof o.spacing);
    o.sform_code = ref.sform_code;
    o.qform_code = ref.qform_code;
    o.xyzt_units = ref.xyzt_units;
    o.voxel_type = voxel_type;
    o.bytes_per_voxel = nifti_voxel_type_size(voxel_type);
    o.datatype = nifti_datatype_for_voxel_type(voxel_type);
    o.scl_slope = 1.0;
    o.scl_inter = 0.0;
    o.intent_code = kNiftiIntentLabel;
    o.descrip = "ffseg labels";
    o.data.assign(size_t(o.voxel_count() * uint64_t(o.bytes_per_voxel)), 0);
    return o;
}

}  // namespace ffseg_tools
