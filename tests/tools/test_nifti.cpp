// Tests for tools/io/nifti.{h,cpp}: strict NIfTI-1 reader / writer.
#include <doctest/doctest.h>

#include "support/gzip_bytes.h"

#include "byte_io.h"
#include "nifti.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

using namespace ffseg_tools;

namespace {

using Bytes = std::vector<uint8_t>;

template <class T>
void put(Bytes& b, size_t off, T v) {
    REQUIRE(off + sizeof v <= b.size());
    std::memcpy(b.data() + off, &v, sizeof v);
}
template <class T>
T get(const Bytes& b, size_t off) {
    T v;
    std::memcpy(&v, b.data() + off, sizeof v);
    return v;
}

// Header offsets (NIfTI-1).
enum : size_t {
    kSizeofHdr = 0, kDim = 40, kDatatype = 70, kBitpix = 72, kPixdim = 76, kVoxOffset = 108,
    kSclSlope = 112, kSclInter = 116, kQformCode = 252, kSformCode = 254, kQuatern = 256,
    kQoffset = 268, kSrow = 280, kMagic = 344,
};

// A rotated (about an oblique axis), anisotropic, translated affine whose
// entries are exactly representable as float.
void rotated_affine(double* m) {
    // Rotation by the unit quaternion (a,b,c,d) = (0.5, 0.5, 0.5, 0.5) is a
    // permutation; use a less trivial one: 3-4-5 style rational rotation.
    // R = [[0.6,-0.8,0],[0.8,0.6,0],[0,0,1]] then about x by [[1,0,0],[0,0.28,-0.96],[0,0.96,0.28]].
    const double Rz[9] = {0.6, -0.8, 0, 0.8, 0.6, 0, 0, 0, 1};
    const double Rx[9] = {1, 0, 0, 0, 0.28, -0.96, 0, 0.96, 0.28};
    double R[9];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            double s = 0;
            for (int k = 0; k < 3; ++k) s += Rx[3 * r + k] * Rz[3 * k + c];
            R[3 * r + c] = s;
        }
    const double sp[3] = {0.75, 1.25, 2.5};
    const double t[3] = {-91.5, 12.25, 40.0};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) m[4 * r + c] = double(float(R[3 * r + c] * sp[c]));
        m[4 * r + 3] = t[r];
    }
    m[12] = m[13] = m[14] = 0;
    m[15] = 1;
}

NiftiImage make_image(int vt, int nx, int ny, int nz) {
    NiftiImage img;
    img.dims[0] = nx;
    img.dims[1] = ny;
    img.dims[2] = nz;
    img.voxel_type = vt;
    img.bytes_per_voxel = nifti_voxel_type_size(vt);
    img.data.resize(img.voxel_count() * uint64_t(img.bytes_per_voxel));
    const size_t n = size_t(img.voxel_count());
    for (size_t i = 0; i < n; ++i) {
        uint8_t* p = img.data.data() + i * size_t(img.bytes_per_voxel);
        const long v = long(i * 37 % 251) - 100;  // includes negatives
        switch (vt) {
            case kNiftiVoxU8: { uint8_t x = uint8_t(i * 7); std::memcpy(p, &x, 1); break; }
            case kNiftiVoxI16: { int16_t x = int16_t(v * 130); std::memcpy(p, &x, 2); break; }
            case kNiftiVoxU16: { uint16_t x = uint16_t(i * 263); std::memcpy(p, &x, 2); break; }
            case kNiftiVoxI32: { int32_t x = int32_t(v * 1000003); std::memcpy(p, &x, 4); break; }
            case kNiftiVoxF32: { float x = float(v) * 0.1f + 1e-3f; std::memcpy(p, &x, 4); break; }
            case kNiftiVoxF64: { double x = double(v) / 3.0 + 1e-12; std::memcpy(p, &x, 8); break; }
        }
    }
    rotated_affine(img.index_to_world);
    img.sform_code = 2;
    img.qform_code = 1;
    img.descrip = "ffseg test";
    return img;
}

Bytes encode(const NiftiImage& img, bool gzip = false) {
    Bytes b;
    std::string err;
    REQUIRE_MESSAGE(nifti_encode(img, gzip, &b, &err), err);
    return b;
}

using ffseg_test::gzip_bytes;

bool read_mem(const Bytes& b, NiftiImage* img, std::string* err, const NiftiLimits& lim = {}) {
    return nifti_read_memory(b.data(), b.size(), img, err, lim);
}

NiftiImage read_ok(const Bytes& b) {
    NiftiImage img;
    std::string err;
    REQUIRE_MESSAGE(read_mem(b, &img, &err), err);
    return img;
}

void check_affine_eq(const double* a, const double* b, double tol) {
    for (int i = 0; i < 16; ++i) CHECK_MESSAGE(std::fabs(a[i] - b[i]) <= tol, "element ", i, ": ", a[i], " vs ", b[i]);
}

// Test-local byte swap of a native single-file NIfTI-1 (header numeric
// fields and the voxel data), written independently of the reader's table.
Bytes byte_swapped(const Bytes& in, int elem_bytes) {
    Bytes b = in;
    auto sw = [&](size_t off, int size, int count) {
        for (int k = 0; k < count; ++k) std::reverse(b.begin() + long(off) + k * size, b.begin() + long(off) + (k + 1) * size);
    };
    sw(0, 4, 1);      // sizeof_hdr
    sw(32, 4, 1);     // extents
    sw(36, 2, 1);     // session_error
    for (int i = 0; i < 8; ++i) sw(40 + 2 * size_t(i), 2, 1);  // dim
    sw(56, 4, 3);     // intent_p
    sw(68, 2, 1);     // intent_code
    sw(70, 2, 1);     // datatype
    sw(72, 2, 1);     // bitpix
    sw(74, 2, 1);     // slice_start
    sw(76, 4, 8);     // pixdim
    sw(108, 4, 1);    // vox_offset
    sw(112, 4, 1);    // scl_slope
    sw(116, 4, 1);    // scl_inter
    sw(120, 2, 1);    // slice_end
    sw(124, 4, 4);    // cal_max .. toffset
    sw(140, 4, 2);    // glmax, glmin
    sw(252, 2, 1);    // qform_code
    sw(254, 2, 1);    // sform_code
    sw(256, 4, 6);    // quatern, qoffset
    sw(280, 4, 12);   // srow
    const size_t vo = size_t(get<float>(in, kVoxOffset));
    sw(vo, elem_bytes, int((in.size() - vo) / size_t(elem_bytes)));
    return b;
}

std::string temp_dir() {
    char tmpl[] = "/tmp/ffseg_nifti_test.XXXXXX";
    const char* d = mkdtemp(tmpl);
    REQUIRE(d != nullptr);
    return d;
}

int count_dir_entries(const std::string& dir) {
    DIR* d = opendir(dir.c_str());
    if (!d) return -1;
    int n = 0;
    while (dirent* e = readdir(d))
        if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) ++n;
    closedir(d);
    return n;
}

void remove_dir(const std::string& dir) {
    DIR* d = opendir(dir.c_str());
    if (!d) return;
    while (dirent* e = readdir(d))
        if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0)
            ::unlink((dir + "/" + e->d_name).c_str());
    closedir(d);
    ::rmdir(dir.c_str());
}

const int kAllTypes[] = {kNiftiVoxU8, kNiftiVoxI16, kNiftiVoxU16, kNiftiVoxI32, kNiftiVoxF32, kNiftiVoxF64};

}  // namespace

TEST_CASE("nifti: round trip of every voxel type through .nii and .nii.gz") {
    const std::string dir = temp_dir();
    for (int vt : kAllTypes) {
        for (bool gz : {false, true}) {
            CAPTURE(vt);
            CAPTURE(gz);
            const NiftiImage img = make_image(vt, 5, 4, 3);
            const std::string path = dir + (gz ? "/img.nii.gz" : "/img.nii");
            std::string err;
            REQUIRE_MESSAGE(nifti_write_file(path, img, &err), err);
            for (int via_memory = 0; via_memory < 2; ++via_memory) {
                NiftiImage r;
                if (via_memory) {
                    FILE* f = std::fopen(path.c_str(), "rb");
                    REQUIRE(f);
                    Bytes b;
                    uint8_t buf[4096];
                    size_t k;
                    while ((k = std::fread(buf, 1, sizeof buf, f)) > 0) b.insert(b.end(), buf, buf + k);
                    std::fclose(f);
                    CHECK((b.size() >= 2 && b[0] == 0x1f && b[1] == 0x8b) == gz);
                    REQUIRE_MESSAGE(read_mem(b, &r, &err), err);
                } else {
                    REQUIRE_MESSAGE(nifti_read_file(path, &r, &err), err);
                }
                CHECK(r.dims[0] == 5);
                CHECK(r.dims[1] == 4);
                CHECK(r.dims[2] == 3);
                CHECK(r.voxel_type == vt);
                CHECK(r.bytes_per_voxel == nifti_voxel_type_size(vt));
                CHECK(r.datatype == nifti_datatype_for_voxel_type(vt));
                CHECK(r.data == img.data);
                CHECK(r.which_affine == "sform");
                CHECK(r.sform_code == 2);
                CHECK(r.qform_code == 1);
                CHECK(r.descrip == "ffseg test");
                CHECK(r.scl_slope == 1.0);
                CHECK(r.scl_inter == 0.0);
                CHECK(r.raw_header.size() == 348);
                check_affine_eq(r.index_to_world, img.index_to_world, 0.0);  // exact
                CHECK(r.spacing[0] == doctest::Approx(0.75));
                CHECK(r.spacing[1] == doctest::Approx(1.25));
                CHECK(r.spacing[2] == doctest::Approx(2.5));
            }
        }
    }
    CHECK(count_dir_entries(dir) == 2);  // img.nii, img.nii.gz; no temporaries left
    remove_dir(dir);
}

TEST_CASE("nifti: rotated anisotropic affine through sform and through qform only") {
    NiftiImage img = make_image(kNiftiVoxF32, 6, 5, 4);
    Bytes b = encode(img);

    SUBCASE("sform (exact)") {
        NiftiImage r = read_ok(b);
        CHECK(r.which_affine == "sform");
        check_affine_eq(r.index_to_world, img.index_to_world, 0.0);
    }
    SUBCASE("qform only (float quaternion precision)") {
        put<int16_t>(b, kSformCode, 0);
        NiftiImage r = read_ok(b);
        CHECK(r.which_affine == "qform");
        check_affine_eq(r.index_to_world, img.index_to_world, 2e-5);
        CHECK(r.spacing[0] == doctest::Approx(0.75));
        CHECK(r.spacing[1] == doctest::Approx(1.25));
        CHECK(r.spacing[2] == doctest::Approx(2.5));
        CHECK(get<float>(b, kPixdim) == 1.0f);  // qfac: proper rotation
    }
    SUBCASE("neither: pixdim diagonal") {
        put<int16_t>(b, kSformCode, 0);
        put<int16_t>(b, kQformCode, 0);
        NiftiImage r = read_ok(b);
        CHECK(r.which_affine == "pixdim");
        const double expect[16] = {0.75, 0, 0, 0, 0, 1.25, 0, 0, 0, 0, 2.5, 0, 0, 0, 0, 1};
        check_affine_eq(r.index_to_world, expect, 1e-6);
    }
    SUBCASE("reflection (LAS-like, det < 0) stored with qfac = -1") {
        // Flip the i axis: det < 0.
        for (int r = 0; r < 3; ++r) img.index_to_world[4 * r] = -img.index_to_world[4 * r];
        Bytes b2 = encode(img);
        CHECK(get<float>(b2, kPixdim) == -1.0f);
        put<int16_t>(b2, kSformCode, 0);
        NiftiImage r = read_ok(b2);
        CHECK(r.which_affine == "qform");
        check_affine_eq(r.index_to_world, img.index_to_world, 2e-5);
    }
    SUBCASE("180 degree rotation (quaternion a = 0) survives") {
        const double m[16] = {-2, 0, 0, 10, 0, -3, 0, 20, 0, 0, 4, 30, 0, 0, 0, 1};
        std::memcpy(img.index_to_world, m, sizeof m);
        Bytes b2 = encode(img);
        put<int16_t>(b2, kSformCode, 0);
        NiftiImage r = read_ok(b2);
        check_affine_eq(r.index_to_world, m, 1e-6);
    }
    SUBCASE("sheared sform: qform is the nearest rigid part") {
        const double m[16] = {1, 0.2, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        std::memcpy(img.index_to_world, m, sizeof m);
        Bytes b2 = encode(img);
        NiftiImage r = read_ok(b2);
        check_affine_eq(r.index_to_world, m, 1e-7);  // sform keeps the shear
        put<int16_t>(b2, kSformCode, 0);
        NiftiImage q = read_ok(b2);  // qform is a valid rigid transform
        CHECK(q.which_affine == "qform");
        const double n = std::sqrt(q.index_to_world[0] * q.index_to_world[0] + q.index_to_world[4] * q.index_to_world[4] +
                                   q.index_to_world[8] * q.index_to_world[8]);
        CHECK(n == doctest::Approx(1.0).epsilon(1e-5));
    }
}

TEST_CASE("nifti: byte-swapped files read identically") {
    for (int vt : kAllTypes) {
        CAPTURE(vt);
        NiftiImage img = make_image(vt, 3, 4, 5);
        const Bytes native = encode(img);
        const Bytes swapped = byte_swapped(native, img.bytes_per_voxel);
        CHECK(swapped != native);
        // sizeof_hdr of the swapped file is the byte-reversed 348.
        CHECK(get<int32_t>(swapped, 0) != 348);
        for (bool gz : {false, true}) {
            NiftiImage r = read_ok(gz ? gzip_bytes(swapped) : swapped);
            CHECK(r.data == img.data);
            check_affine_eq(r.index_to_world, img.index_to_world, 0.0);
            CHECK(r.datatype == nifti_datatype_for_voxel_type(vt));
            CHECK(r.raw_header == Bytes(native.begin(), native.begin() + 348));  // native order
        }
        // qform path of a swapped header too.
        Bytes q = native;
        put<int16_t>(q, kSformCode, 0);
        NiftiImage rq = read_ok(byte_swapped(q, img.bytes_per_voxel));
        CHECK(rq.which_affine == "qform");
        check_affine_eq(rq.index_to_world, img.index_to_world, 2e-5);
    }
}

TEST_CASE("nifti: widened datatypes int8, uint32, int64, uint64") {
    // Start from a uint8 file and rewrite datatype/bitpix/data by hand.
    NiftiImage base = make_image(kNiftiVoxU8, 2, 2, 2);
    const Bytes full = encode(base);
    const Bytes hdr(full.begin(), full.begin() + 352);
    auto with = [&](int16_t dt, int16_t bitpix, const void* vals, size_t nbytes) {
        Bytes b = hdr;
        put<int16_t>(b, kDatatype, dt);
        put<int16_t>(b, kBitpix, bitpix);
        const uint8_t* p = static_cast<const uint8_t*>(vals);
        b.insert(b.end(), p, p + nbytes);
        return b;
    };
    SUBCASE("int8 -> int16") {
        const int8_t v[8] = {-128, -1, 0, 1, 2, 3, 100, 127};
        NiftiImage r = read_ok(with(256, 8, v, sizeof v));
        CHECK(r.voxel_type == kNiftiVoxI16);
        CHECK(r.datatype == 256);
        REQUIRE(r.data.size() == 16);
        for (int i = 0; i < 8; ++i) CHECK(get<int16_t>(r.data, size_t(2 * i)) == v[i]);
    }
    SUBCASE("uint32 -> float64") {
        const uint32_t v[8] = {0, 1, 4294967295u, 123456789u, 7, 8, 9, 2147483648u};
        NiftiImage r = read_ok(with(768, 32, v, sizeof v));
        CHECK(r.voxel_type == kNiftiVoxF64);
        for (int i = 0; i < 8; ++i) CHECK(get<double>(r.data, size_t(8 * i)) == double(v[i]));
    }
    SUBCASE("int64 / uint64 -> float64, and byte-swapped uint32") {
        const int64_t v[8] = {-(int64_t(1) << 53), -1, 0, 1, int64_t(1) << 53, 5, 6, 7};
        NiftiImage r = read_ok(with(1024, 64, v, sizeof v));
        for (int i = 0; i < 8; ++i) CHECK(get<double>(r.data, size_t(8 * i)) == double(v[i]));
        const uint64_t u[8] = {0, 1, uint64_t(1) << 53, 3, 4, 5, 6, 7};
        NiftiImage ru = read_ok(with(1280, 64, u, sizeof u));
        for (int i = 0; i < 8; ++i) CHECK(get<double>(ru.data, size_t(8 * i)) == double(u[i]));
        const uint32_t w[8] = {1, 2, 3, 4000000000u, 5, 6, 7, 8};
        NiftiImage rw = read_ok(byte_swapped(with(768, 32, w, sizeof w), 4));
        for (int i = 0; i < 8; ++i) CHECK(get<double>(rw.data, size_t(8 * i)) == double(w[i]));
    }
}

TEST_CASE("nifti: accepted edge cases") {
    NiftiImage img = make_image(kNiftiVoxI16, 4, 3, 2);
    const Bytes good = encode(img);
    SUBCASE("scl_slope 0 means no scaling") {
        Bytes b = good;
        put<float>(b, kSclSlope, 0.0f);
        put<float>(b, kSclInter, 5.0f);
        NiftiImage r = read_ok(b);
        CHECK(r.scl_slope == 1.0);
        CHECK(r.scl_inter == 0.0);
    }
    SUBCASE("scaling is reported, never applied") {
        Bytes b = good;
        put<float>(b, kSclSlope, 2.5f);
        put<float>(b, kSclInter, -3.0f);
        NiftiImage r = read_ok(b);
        CHECK(r.scl_slope == 2.5);
        CHECK(r.scl_inter == -3.0);
        CHECK(r.data == img.data);
    }
    SUBCASE("4D with dim[4] = 1 and 2D images") {
        Bytes b = good;
        put<int16_t>(b, kDim, 4);
        put<int16_t>(b, kDim + 8, 1);
        CHECK(read_ok(b).dims[2] == 2);
        Bytes b2 = good;
        put<int16_t>(b2, kDim, 2);
        b2.resize(352 + 4 * 3 * 2);  // one slice
        NiftiImage r = read_ok(b2);
        CHECK(r.dims[2] == 1);
        CHECK(r.data.size() == 24);
    }
    SUBCASE("pixdim zero or negative is fine when the sform is used") {
        Bytes b = good;
        put<float>(b, kPixdim + 4, 0.0f);
        put<float>(b, kPixdim + 8, -2.0f);
        NiftiImage r = read_ok(b);
        CHECK(r.which_affine == "sform");
        CHECK(r.spacing[1] == doctest::Approx(1.25));
    }
    SUBCASE("qform_code 0 with garbage quaternion is ignored (as in ch2.nii.gz)") {
        Bytes b = good;
        put<int16_t>(b, kQformCode, 0);
        put<float>(b, kQuatern, 7.0f);
        CHECK(read_ok(b).which_affine == "sform");
    }
    SUBCASE("vox_offset beyond 352 with an extension block") {
        Bytes b(good.begin(), good.begin() + 352);
        b[348] = 1;  // extension flag
        b.resize(400, 0xAB);
        put<float>(b, kVoxOffset, 400.0f);
        b.insert(b.end(), good.begin() + 352, good.end());
        NiftiImage r = read_ok(b);
        CHECK(r.data == img.data);
        CHECK(read_ok(gzip_bytes(b)).data == img.data);
    }
    SUBCASE("multi-member gzip and zero padding after the stream") {
        const Bytes part1(good.begin(), good.begin() + 100), part2(good.begin() + 100, good.end());
        Bytes gz = gzip_bytes(part1);
        const Bytes g2 = gzip_bytes(part2);
        gz.insert(gz.end(), g2.begin(), g2.end());
        CHECK(read_ok(gz).data == img.data);
        gz.resize(gz.size() + 512, 0);
        CHECK(read_ok(gz).data == img.data);
    }
    SUBCASE("gzip trailing data within the slack is tolerated") {
        Bytes b = good;
        b.resize(b.size() + 1000, 0);
        CHECK(read_ok(gzip_bytes(b)).data == img.data);
    }
    SUBCASE("uncompressed trailing bytes are ignored") {
        Bytes b = good;
        b.resize(b.size() + 1000, 7);
        CHECK(read_ok(b).data == img.data);
    }
}

TEST_CASE("nifti: malformed inputs are refused with a specific message") {
    NiftiImage img = make_image(kNiftiVoxI16, 4, 3, 2);
    const Bytes good = encode(img);
    Bytes qonly = good;  // the qform is what is used
    put<int16_t>(qonly, kSformCode, 0);
    Bytes nothing = qonly;  // neither transform: the pixdim diagonal is used
    put<int16_t>(nothing, kQformCode, 0);

    struct Case {
        const char* name;
        std::function<Bytes()> make;
        const char* expect;
        NiftiLimits lim;
    };
    auto mut = [](const Bytes& base, std::function<void(Bytes&)> f) {
        return [base, f]() {
            Bytes b = base;
            f(b);
            return b;
        };
    };
    NiftiLimits small;
    small.max_bytes = 1 << 20;
    NiftiLimits bomb_lim;
    bomb_lim.slack_bytes = 4096;

    const std::vector<Case> cases = {
        {"empty file", [] { return Bytes(); }, "empty file", {}},
        {"10-byte file", [&] { return Bytes(good.begin(), good.begin() + 10); }, "too short", {}},
        {"header cut at 347 bytes", [&] { return Bytes(good.begin(), good.begin() + 347); }, "too short", {}},
        {"sizeof_hdr wrong", mut(good, [](Bytes& b) { put<int32_t>(b, kSizeofHdr, 349); }), "bad sizeof_hdr 349", {}},
        {"NIfTI-2 sizeof_hdr", mut(good, [](Bytes& b) { put<int32_t>(b, kSizeofHdr, 540); }), "NIfTI-2", {}},
        {"magic ni1 (hdr/img pair)", mut(good, [](Bytes& b) { std::memcpy(b.data() + kMagic, "ni1", 4); }), ".hdr/.img", {}},
        {"magic n+2", mut(good, [](Bytes& b) { std::memcpy(b.data() + kMagic, "n+2", 4); }), "NIfTI-2", {}},
        {"magic garbage", mut(good, [](Bytes& b) { std::memcpy(b.data() + kMagic, "xyz", 4); }), "bad magic", {}},
        {"ANALYZE 7.5 (no magic)", mut(good, [](Bytes& b) { std::memset(b.data() + kMagic, 0, 4); }), "bad magic", {}},
        {"dim[0] = 0", mut(good, [](Bytes& b) { put<int16_t>(b, kDim, 0); }), "dim[0] = 0 out of range", {}},
        {"dim[0] = 8", mut(good, [](Bytes& b) { put<int16_t>(b, kDim, 8); }), "dim[0] = 8 out of range", {}},
        {"negative dim", mut(good, [](Bytes& b) { put<int16_t>(b, kDim + 4, -5); }), "dim[2] = -5 must be positive", {}},
        {"zero dim", mut(good, [](Bytes& b) { put<int16_t>(b, kDim + 2, 0); }), "dim[1] = 0 must be positive", {}},
        {"dims overflow 64 bits",
         mut(good, [](Bytes& b) { put<int16_t>(b, kDim, 7); for (int i = 1; i <= 7; ++i) put<int16_t>(b, kDim + 2 * size_t(i), 32767); }),
         "overflows 64 bits", {}},
        {"4D with dim[4] = 2", mut(good, [](Bytes& b) { put<int16_t>(b, kDim, 4); put<int16_t>(b, kDim + 8, 2); }), "only 3D", {}},
        {"unknown datatype", mut(good, [](Bytes& b) { put<int16_t>(b, kDatatype, 999); }), "unknown datatype 999", {}},
        {"complex datatype", mut(good, [](Bytes& b) { put<int16_t>(b, kDatatype, 32); put<int16_t>(b, kBitpix, 64); }), "complex64) is not supported", {}},
        {"RGB datatype", mut(good, [](Bytes& b) { put<int16_t>(b, kDatatype, 128); put<int16_t>(b, kBitpix, 24); }), "rgb24", {}},
        {"bitpix mismatch", mut(good, [](Bytes& b) { put<int16_t>(b, kBitpix, 8); }), "bitpix 8 does not match", {}},
        {"vox_offset 348 (< 352)", mut(good, [](Bytes& b) { put<float>(b, kVoxOffset, 348.0f); }), "below 352", {}},
        {"vox_offset NaN", mut(good, [](Bytes& b) { put<float>(b, kVoxOffset, std::nanf("")); }), "vox_offset is not finite", {}},
        {"vox_offset fractional", mut(good, [](Bytes& b) { put<float>(b, kVoxOffset, 352.5f); }), "not an integer", {}},
        {"vox_offset huge", mut(good, [](Bytes& b) { put<float>(b, kVoxOffset, 1e20f); }), "exceeds the limit", {}},
        {"vox_offset past end", mut(good, [](Bytes& b) { put<float>(b, kVoxOffset, 4096.0f); }), "past the end", {}},
        {"vox_offset past end (gzip)", [&] { Bytes b = good; put<float>(b, kVoxOffset, 4096.0f); return gzip_bytes(b); }, "past the end", {}},
        {"data truncated", [&] { return Bytes(good.begin(), good.end() - 1); }, "voxel data truncated", {}},
        {"header claims 1 GiB, file is tiny", mut(good, [](Bytes& b) { put<int16_t>(b, kDim + 2, 1024); put<int16_t>(b, kDim + 4, 1024); put<int16_t>(b, kDim + 6, 512); }), "voxel data truncated", {}},
        {"gzip: header claims 1 GiB, stream is tiny", [&] { Bytes b = good; put<int16_t>(b, kDim + 2, 1024); put<int16_t>(b, kDim + 4, 1024); put<int16_t>(b, kDim + 6, 512); return gzip_bytes(b); }, "voxel data truncated", {}},
        {"data missing", [&] { return Bytes(good.begin(), good.begin() + 352); }, "voxel data truncated", {}},
        {"pixdim NaN", mut(good, [](Bytes& b) { put<float>(b, kPixdim + 8, std::nanf("")); }), "pixdim[2] is not finite", {}},
        {"pixdim Inf", mut(good, [](Bytes& b) { put<float>(b, kPixdim + 12, INFINITY); }), "pixdim[3] is not finite", {}},
        {"pixdim zero (qform used)", mut(qonly, [](Bytes& b) { put<float>(b, kPixdim + 4, 0.0f); }), "pixdim[1] = 0 must be > 0", {}},
        {"pixdim negative (qform used)", mut(qonly, [](Bytes& b) { put<float>(b, kPixdim + 12, -2.5f); }), "pixdim[3] = -2.5 must be > 0", {}},
        {"pixdim zero (no transform)", mut(nothing, [](Bytes& b) { put<float>(b, kPixdim + 8, 0.0f); }), "used by the pixdim affine", {}},
        {"qfac NaN (qform used)", mut(qonly, [](Bytes& b) { put<float>(b, kPixdim, std::nanf("")); }), "qfac", {}},
        {"qform quaternion NaN", mut(good, [](Bytes& b) { put<float>(b, kQuatern + 4, std::nanf("")); }), "quaternion (quatern_b/c/d) is not finite", {}},
        {"qform quaternion not unit", mut(good, [](Bytes& b) { put<float>(b, kQuatern, 0.9f); put<float>(b, kQuatern + 4, 0.9f); }), "not a unit quaternion", {}},
        {"qoffset Inf", mut(good, [](Bytes& b) { put<float>(b, kQoffset + 8, -INFINITY); }), "qoffset", {}},
        {"qform_code out of range", mut(good, [](Bytes& b) { put<int16_t>(b, kQformCode, 7); }), "qform_code 7 out of range", {}},
        {"sform_code negative", mut(good, [](Bytes& b) { put<int16_t>(b, kSformCode, -1); }), "sform_code -1 out of range", {}},
        {"sform NaN", mut(good, [](Bytes& b) { put<float>(b, kSrow + 16 + 4, std::nanf("")); }), "srow_y is not finite", {}},
        {"sform singular (zero column)",
         mut(good, [](Bytes& b) { for (int r = 0; r < 3; ++r) put<float>(b, kSrow + 16 * size_t(r) + 4, 0.0f); }), "sform is singular", {}},
        {"sform singular (dependent rows)",
         mut(good, [](Bytes& b) { for (int c = 0; c < 4; ++c) put<float>(b, kSrow + 32 + 4 * size_t(c), 2 * get<float>(b, kSrow + 4 * size_t(c))); }),
         "sform is singular", {}},
        {"scl_slope NaN", mut(good, [](Bytes& b) { put<float>(b, kSclSlope, std::nanf("")); }), "scl_slope is not finite", {}},
        {"scl_inter Inf", mut(good, [](Bytes& b) { put<float>(b, kSclInter, INFINITY); }), "scl_inter is not finite", {}},
        {"scl_inter Inf with zero slope", mut(good, [](Bytes& b) { put<float>(b, kSclSlope, 0.0f); put<float>(b, kSclInter, INFINITY); }), "scl_inter is not finite", {}},
        {"byte-swapped with bad dim[0]", [&] { Bytes b = good; put<int16_t>(b, kDim, 9); return byte_swapped(b, 2); }, "dim[0] = 9", {}},
        {"gzip truncated", [&] { Bytes z = gzip_bytes(good); z.resize(z.size() - 9); return z; }, "gzip stream truncated", {}},
        {"gzip cut inside the header", [&] { Bytes z = gzip_bytes(good); z.resize(20); return z; }, "gzip stream truncated", {}},
        {"gzip corrupt deflate data", [&] { Bytes z = gzip_bytes(good); z[10] |= 0x06; return z; }, "gzip data corrupt", {}},  // BTYPE = 3
        {"gzip bad header flags", [&] { Bytes z = gzip_bytes(good); z[2] = 7; return z; }, "gzip data corrupt", {}},  // method != deflate
        {"gzip bad CRC", [&] { Bytes z = gzip_bytes(good); z[z.size() - 6] ^= 0xFF; return z; }, "gzip data corrupt", {}},
        {"gzip garbage after padding", [&] { Bytes z = gzip_bytes(good); z.push_back(0); z.push_back(0); z.push_back(1); return z; }, "garbage", {}},
        {"gzip empty content", [] { return gzip_bytes(Bytes()); }, "empty file (after gzip", {}},
        {"gzip bomb beyond the bound", [&] { Bytes b = good; b.resize(b.size() + (size_t(16) << 20), 0); return gzip_bytes(b, 9); }, "decompression bound", bomb_lim},
        {"image larger than max_bytes", mut(good, [](Bytes& b) { put<int16_t>(b, kDim + 2, 1024); put<int16_t>(b, kDim + 4, 1024); }), "NiftiLimits::max_bytes", small},
        {"gzip header claims more than max_bytes", [&] { Bytes b = good; put<int16_t>(b, kDim + 2, 1024); put<int16_t>(b, kDim + 4, 1024); return gzip_bytes(b); }, "NiftiLimits::max_bytes", small},
    };
    CHECK(cases.size() >= 25);
    for (const Case& c : cases) {
        CAPTURE(c.name);
        const Bytes b = c.make();
        NiftiImage r;
        std::string err;
        const bool ok = read_mem(b, &r, &err, c.lim);
        CHECK_MESSAGE(!ok, c.name);
        CHECK_MESSAGE(err.find(c.expect) != std::string::npos, c.name, ": got \"", err, "\", expected \"", c.expect, "\"");
    }
}

TEST_CASE("nifti: gzip bomb is refused without allocating it") {
    // 256 MiB of zeros compresses to ~256 KiB; built incrementally so the test
    // itself stays small.  The header claims a 4x3x2 image.
    NiftiImage img = make_image(kNiftiVoxU8, 4, 3, 2);
    const Bytes good = encode(img);
    z_stream zs;
    std::memset(&zs, 0, sizeof zs);
    REQUIRE(deflateInit2(&zs, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) == Z_OK);
    Bytes out;
    Bytes buf(1 << 16);
    Bytes zeros(1 << 20, 0);
    auto pump = [&](const uint8_t* p, size_t n, int flush) {
        zs.next_in = const_cast<uint8_t*>(p);
        zs.avail_in = uInt(n);
        do {
            zs.next_out = buf.data();
            zs.avail_out = uInt(buf.size());
            deflate(&zs, flush);
            out.insert(out.end(), buf.data(), buf.data() + (buf.size() - zs.avail_out));
        } while (zs.avail_out == 0);
    };
    pump(good.data(), good.size(), Z_NO_FLUSH);
    for (int i = 0; i < 256; ++i) pump(zeros.data(), zeros.size(), Z_NO_FLUSH);
    pump(nullptr, 0, Z_FINISH);
    deflateEnd(&zs);
    CHECK(out.size() < (size_t(4) << 20));
    NiftiImage r;
    std::string err;
    CHECK_FALSE(read_mem(out, &r, &err));
    CHECK(err.find("decompression bound") != std::string::npos);
}

TEST_CASE("nifti: a gzip volume over a known compressed size is read into one buffer") {
    // 3 MiB of pseudo-random int16 voxels (they deflate about 1:1): the
    // buffer starts at 4x the compressed bytes, so it is never regrown (from
    // 1 MB it grew to 2 and 4 MiB, copying and zero-filling each time).
    NiftiImage img = make_image(kNiftiVoxI16, 128, 128, 96);
    uint64_t state = 12345;
    for (size_t i = 0; i < img.data.size(); ++i) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        img.data[i] = uint8_t(state >> 56);
    }
    const Bytes gz = encode(img, true);
    const NiftiImage r = read_ok(gz);
    CHECK(r.data == img.data);
    CHECK(r.data.size() > (size_t(1) << 20));
    CHECK(r.data.capacity() == r.data.size());
    // Over memory the compressed size is known as well.
    ffseg_tools::io::MemSource mem(gz.data(), gz.size());
    ffseg_tools::io::GzipSource unz(mem);
    std::string err;
    REQUIRE(unz.init(&err));
    uint64_t left = 0;
    REQUIRE(unz.compressed_remaining(&left));
    CHECK(left == gz.size());
}

TEST_CASE("nifti: writer errors and atomic writes") {
    const std::string dir = temp_dir();
    NiftiImage img = make_image(kNiftiVoxU8, 3, 3, 3);
    std::string err;
    CHECK_FALSE(nifti_write_file(dir + "/x.img", img, &err));
    CHECK(err.find("use .nii or .nii.gz") != std::string::npos);
    NiftiImage bad = img;
    bad.data.pop_back();
    CHECK_FALSE(nifti_write_file(dir + "/x.nii", bad, &err));
    CHECK(err.find("data has") != std::string::npos);
    bad = img;
    bad.index_to_world[5] = 0;
    bad.index_to_world[4] = 0;
    bad.index_to_world[6] = 0;
    bad.index_to_world[1] = 0;
    bad.index_to_world[9] = 0;
    CHECK_FALSE(nifti_write_file(dir + "/x.nii.gz", bad, &err));
    CHECK(err.find("singular") != std::string::npos);
    bad = img;
    bad.voxel_type = 42;
    CHECK_FALSE(nifti_write_file(dir + "/x.nii", bad, &err));
    CHECK(err.find("voxel_type") != std::string::npos);
    CHECK(count_dir_entries(dir) == 0);
    // Directory that does not exist: nothing created anywhere.
    CHECK_FALSE(nifti_write_file(dir + "/nope/x.nii", img, &err));
    CHECK(err.find("temporary") != std::string::npos);
    // Overwrite an existing file atomically.
    REQUIRE(nifti_write_file(dir + "/x.nii.GZ", img, &err));
    img.data[0] = 99;
    REQUIRE(nifti_write_file(dir + "/x.nii.GZ", img, &err));
    NiftiImage r;
    REQUIRE_MESSAGE(nifti_read_file(dir + "/x.nii.GZ", &r, &err), err);
    CHECK(r.data == img.data);
    CHECK(count_dir_entries(dir) == 1);
    CHECK_FALSE(nifti_read_file(dir + "/missing.nii", &r, &err));
    CHECK(err.find("cannot open") != std::string::npos);
    remove_dir(dir);
}

TEST_CASE("nifti: label image copies the geometry") {
    NiftiImage ref = make_image(kNiftiVoxF32, 7, 6, 5);
    NiftiImage lab = nifti_make_label_image(ref);
    CHECK(lab.voxel_type == kNiftiVoxU8);
    CHECK(lab.data.size() == 7 * 6 * 5);
    CHECK(lab.intent_code == kNiftiIntentLabel);
    lab.data[3] = 5;
    NiftiImage r = read_ok(encode(lab, true));
    CHECK(r.dims[0] == 7);
    CHECK(r.dims[2] == 5);
    CHECK(r.datatype == kNiftiDtUint8);
    CHECK(r.intent_code == kNiftiIntentLabel);
    CHECK(r.sform_code == ref.sform_code);
    CHECK(r.qform_code == ref.qform_code);
    CHECK(r.data == lab.data);
    check_affine_eq(r.index_to_world, ref.index_to_world, 0.0);
    NiftiImage l16 = nifti_make_label_image(ref, kNiftiVoxI16);
    CHECK(l16.data.size() == 2 * 7 * 6 * 5);
}

namespace {
// world (mm) -> nearest voxel index, by solving the affine.
bool world_to_voxel(const NiftiImage& img, const double* w, int* ijk) {
    const double* m = img.index_to_world;
    const double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
    const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    const double x = w[0] - m[3], y = w[1] - m[7], z = w[2] - m[11];
    const double inv[9] = {(e * i - f * h), -(b * i - c * h), (b * f - c * e), -(d * i - f * g), (a * i - c * g),
                           -(a * f - c * d), (d * h - e * g), -(a * h - b * g), (a * e - b * d)};
    for (int r = 0; r < 3; ++r) {
        const double v = (inv[3 * r] * x + inv[3 * r + 1] * y + inv[3 * r + 2] * z) / det;
        ijk[r] = int(std::lround(v));
        if (ijk[r] < 0 || ijk[r] >= img.dims[r]) return false;
    }
    return true;
}
int u8_at_mm(const NiftiImage& img, double x, double y, double z) {
    const double w[3] = {x, y, z};
    int ijk[3];
    if (!world_to_voxel(img, w, ijk)) return -1;
    return img.data[size_t(ijk[0]) + size_t(img.dims[0]) * (size_t(ijk[1]) + size_t(img.dims[1]) * size_t(ijk[2]))];
}
}  // namespace

TEST_CASE("nifti: Colin27 / AAL templates from mricron") {
    const char* dir = "/usr/share/mricron/templates/";
    const char* names[] = {"ch2.nii.gz", "aal.nii.gz", "ch2bet.nii.gz"};
    for (const char* n : names) {
        const std::string path = std::string(dir) + n;
        if (::access(path.c_str(), R_OK) != 0) {
            MESSAGE("skipping, not installed: ", path);
            continue;
        }
        CAPTURE(path);
        NiftiImage img;
        std::string err;
        REQUIRE_MESSAGE(nifti_read_file(path, &img, &err), err);
        CHECK(img.dims[0] == 181);
        CHECK(img.dims[1] == 217);
        CHECK(img.dims[2] == 181);
        CHECK(img.datatype == kNiftiDtUint8);
        CHECK(img.voxel_type == kNiftiVoxU8);
        CHECK(img.which_affine == "sform");
        CHECK(img.sform_code == 4);  // MNI152
        const double expect[16] = {1, 0, 0, -90, 0, 1, 0, -125, 0, 0, 1, -71, 0, 0, 0, 1};
        check_affine_eq(img.index_to_world, expect, 0.0);
        for (int i = 0; i < 3; ++i) CHECK(img.spacing[i] == 1.0);
        // Voxel (90, 125, 71) is the MNI origin; the volume centre is near it.
        const double cx = img.index_to_world[3] + 0.5 * (img.dims[0] - 1);
        const double cy = img.index_to_world[7] + 0.5 * (img.dims[1] - 1);
        const double cz = img.index_to_world[11] + 0.5 * (img.dims[2] - 1);
        CHECK(std::fabs(cx) < 5);
        CHECK(std::fabs(cy + 17) < 5);
        CHECK(std::fabs(cz - 19) < 5);
        int lo = 255, hi = 0;
        size_t nonzero = 0;
        for (uint8_t v : img.data) {
            lo = std::min<int>(lo, v);
            hi = std::max<int>(hi, v);
            nonzero += v != 0;
        }
        MESSAGE(std::string(n), ": dims 181x217x181 uint8, spacing 1 mm, sform (MNI), range [", lo, ", ", hi, "], nonzero ",
                nonzero, ", descrip \"", img.descrip, "\", qform_code ", img.qform_code, ", scl ", img.scl_slope, "/",
                img.scl_inter);
        CHECK(lo == 0);
        if (std::string(n) == "aal.nii.gz") {
            CHECK(hi == 116);  // 116 AAL regions
            // Known anatomy at MNI coordinates (labels from aal.nii.txt).
            CHECK(u8_at_mm(img, -40, -20, 50) == 57);  // Postcentral_L
            CHECK(u8_at_mm(img, 40, -20, 50) == 58);   // Postcentral_R
            CHECK(u8_at_mm(img, -25, -5, 0) == 75);    // Pallidum_L
            CHECK(u8_at_mm(img, 0, -60, -30) == 114);  // Vermis_8
            CHECK(u8_at_mm(img, 0, 0, 0) == 0);        // origin: between hemispheres
            // Odd labels are left hemisphere: their mean x must be negative.
            double sx[2] = {0, 0};
            size_t cnt[2] = {0, 0};
            for (int k = 0; k < img.dims[2]; ++k)
                for (int j = 0; j < img.dims[1]; ++j)
                    for (int i = 0; i < img.dims[0]; ++i) {
                        const uint8_t v = img.data[size_t(i) + 181 * (size_t(j) + 217 * size_t(k))];
                        if (v == 1 || v == 2) {
                            sx[v - 1] += img.index_to_world[0] * i + img.index_to_world[3];
                            ++cnt[v - 1];
                        }
                    }
            REQUIRE(cnt[0] > 0);
            REQUIRE(cnt[1] > 0);
            CHECK(sx[0] / double(cnt[0]) < -30);  // Precentral_L
            CHECK(sx[1] / double(cnt[1]) > 30);   // Precentral_R
        } else {
            CHECK(hi > 100);
        }
    }
}
