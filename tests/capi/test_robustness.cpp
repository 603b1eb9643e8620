// Robustness (issue 5): a table of named malformed inputs and misuse with the
// status and message each must get; the workspace sweep; two engines in two
// threads; run-to-run determinism; the fuzzers' findings as regression tests.
//
// The malformed-case table here complements two existing tables and does not
// repeat their entries:
//  * tests/capi/test_api_contract.cpp "malformed volumes are refused ..." (24 volume
//    descriptor cases: zero/negative dims, product overflow, NULL data, unknown
//    type, strides past the end, short data, offset/negative stride before the
//    start, aliasing strides, singular/NaN/Inf affine, projective last row,
//    zero/NaN slope, Inf intercept, huge strides);
//  * tests/tools/test_nifti.cpp "nifti: malformed inputs are refused ..." (56 NIfTI
//    cases: sizeof_hdr, magic, dim[0], dims, datatype, bitpix, vox_offset,
//    truncated data, pixdim, qform/sform, scl_slope/scl_inter, gzip).
// Together with the cases below that is well over 40 named cases per the issue.
#include <doctest/doctest.h>

#include "support/gzip_bytes.h"

#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "ffseg.h"
#include "nifti.h"
#include "test_util.h"

using ffseg_test::EngineBox;
using ffseg_test::make_volume;

namespace {

// ---- small binary phantoms ---------------------------------------------------------

constexpr int kN = 32;

// A ball (radius r voxels, centre c in index space) in a 32^3 u8 volume.
std::vector<uint8_t> ball_u8(double cx, double cy, double cz, double r) {
  std::vector<uint8_t> v(size_t(kN) * kN * kN, 0);
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        const double d2 = (i - cx) * (i - cx) + (j - cy) * (j - cy) + (k - cz) * (k - cz);
        v[size_t(i + kN * (j + kN * k))] = d2 <= r * r ? 1 : 0;
      }
  return v;
}

const double kIdentity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
// 1.25 x 1 x 0.8 mm voxels, translated: anisotropic but axis-aligned.
const double kAniso[16] = {1.25, 0, 0, -20, 0, 1, 0, 5, 0, 0, 0.8, 2, 0, 0, 0, 1};

ffseg_volume volume32(const std::vector<uint8_t>& data, const double* A = kIdentity) {
  const int64_t dims[3] = {kN, kN, kN};
  return make_volume(data.data(), FFSEG_U8, dims, A);
}

// Runs a full segmentation on an engine; returns the extracted vertices.
std::vector<float> segment(ffseg_engine* e, const ffseg_volume& v, const double c[3], double r, int steps,
                           const ffseg_params* p = nullptr) {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  if (p) REQUIRE(ffseg_set_params(e, p) == FFSEG_OK);
  REQUIRE(ffseg_set_volume(e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(e, 0, c, r) == FFSEG_OK);
  for (int s = 0; s < steps; ++s) {
    const ffseg_status st = ffseg_step(e, nullptr);
    REQUIRE((st == FFSEG_OK || st == FFSEG_CONVERGED));
  }
  REQUIRE(ffseg_test::extract(e, 0, &xyz, &tris));
  return xyz;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// ---- NIfTI byte helpers --------------------------------------------------------------

using Bytes = std::vector<uint8_t>;

template <class T>
void put(Bytes& b, size_t off, T v) {
  REQUIRE(off + sizeof v <= b.size());
  std::memcpy(b.data() + off, &v, sizeof v);
}

enum : size_t {
  kDim = 40, kDatatype = 70, kBitpix = 72, kPixdim = 76, kVoxOffset = 108, kSclSlope = 112,
  kQformCode = 252, kSformCode = 254, kSrow = 280,
};

Bytes good_nifti(int vt = ffseg_tools::kNiftiVoxI16) {
  ffseg_tools::NiftiImage img;
  img.dims[0] = 5;
  img.dims[1] = 4;
  img.dims[2] = 3;
  img.voxel_type = vt;
  img.bytes_per_voxel = ffseg_tools::nifti_voxel_type_size(vt);
  img.data.assign(img.voxel_count() * uint64_t(img.bytes_per_voxel), 0);
  for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = uint8_t(i * 13);
  const double A[16] = {0.9, 0, 0, -10, 0, 1.1, 0, 4, 0, 0, 2.5, 1, 0, 0, 0, 1};
  std::memcpy(img.index_to_world, A, sizeof A);
  img.sform_code = 2;
  img.qform_code = 1;
  Bytes out;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_encode(img, false, &out, &err), err);
  return out;
}

Bytes gzip(const Bytes& in) { return ffseg_test::gzip_bytes(in); }

// ---- the table -------------------------------------------------------------------------

// What a case produced: an ffseg status (or kReaderRefused / kReaderAccepted
// for the NIfTI reader, which answers with a bool) and the message.
constexpr int kReaderRefused = -1000;
constexpr int kReaderAccepted = 1000;
struct Outcome {
  int status;
  std::string msg;
};

Outcome read_nifti(const Bytes& b) {
  ffseg_tools::NiftiImage img;
  std::string err;
  ffseg_tools::NiftiLimits lim;
  lim.max_bytes = uint64_t(64) << 20;
  const bool ok = ffseg_tools::nifti_read_memory(b.data(), b.size(), &img, &err, lim);
  return {ok ? kReaderAccepted : kReaderRefused, err};
}

// A 10 x 11 x 12 u16 volume and an engine whose set_volume answer is reported.
Outcome volume_case(const std::function<void(ffseg_volume&)>& edit) {
  static std::vector<uint16_t> buf(10 * 11 * 12, 1);
  const int64_t dims[3] = {10, 11, 12};
  ffseg_volume v = make_volume(buf.data(), FFSEG_U16, dims, kIdentity);
  edit(v);
  EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  const ffseg_status st = ffseg_set_volume(eb.e, &v);
  return {st, ffseg_last_error(eb.e)};
}

Outcome params_case(const std::function<void(ffseg_params&)>& edit) {
  EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  edit(p);
  const ffseg_status st = ffseg_set_params(eb.e, &p);
  return {st, ffseg_last_error(eb.e)};
}

Outcome config_case(const std::function<void(ffseg_config&)>& edit) {
  ffseg_config c;
  ffseg_config_init_default(&c);
  edit(c);
  size_t bytes = 0;
  const ffseg_status st = ffseg_workspace_size(&c, &bytes);
  return {st, ffseg_last_error(nullptr)};
}

// An engine (2 objects, n = 4) brought to a given stage, then one call made.
enum class Stage { created, volume, sphere, destroyed };
Outcome call_case(Stage stage, const std::function<ffseg_status(ffseg_engine*)>& call) {
  static const std::vector<uint8_t> data = ball_u8(15.5, 16, 16.5, 8);
  EngineBox eb(2, 4);
  REQUIRE(eb.e != nullptr);
  const ffseg_volume v = volume32(data);
  if (stage != Stage::created) REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double c[3] = {16, 16, 16};
  if (stage == Stage::sphere || stage == Stage::destroyed) REQUIRE(ffseg_init_sphere(eb.e, 0, c, 6) == FFSEG_OK);
  if (stage == Stage::destroyed) ffseg_destroy(eb.e);
  const ffseg_status st = call(eb.e);
  const Outcome o{st, ffseg_last_error(eb.e)};
  if (stage == Stage::destroyed) eb.e = nullptr;  // nothing left to destroy
  return o;
}

struct Case {
  const char* name;
  std::function<Outcome()> run;
  int status;
  const char* msg;
};

std::vector<Case> malformed_cases() {
  std::vector<Case> t = {
      // ---- the volume descriptor (beyond test_api_contract's 24) ----
      {"volume: dims[0] = INT64_MIN", [] { return volume_case([](ffseg_volume& v) { v.dims[0] = INT64_MIN; }); },
       FFSEG_ERR_INVALID_VOLUME, "dims[0]"},
      {"volume: dims 2^32 x 2^31 x 2 overflow", [] {
         return volume_case([](ffseg_volume& v) { v.dims[0] = int64_t(1) << 32; v.dims[1] = int64_t(1) << 31; v.dims[2] = 2; });
       }, FFSEG_ERR_INVALID_VOLUME, "overflows 64 bits"},
      {"volume: f64 voxel count x 8 bytes overflows", [] {
         return volume_case([](ffseg_volume& v) { v.voxel_type = FFSEG_F64; v.dims[0] = int64_t(1) << 61; v.dims[1] = v.dims[2] = 1; });
       }, FFSEG_ERR_INVALID_VOLUME, "voxel count times voxel size"},
      {"volume: offset = data_bytes", [] { return volume_case([](ffseg_volume& v) { v.offset = int64_t(v.data_bytes); }); },
       FFSEG_ERR_INVALID_VOLUME, "past the end"},
      {"volume: offset INT64_MAX", [] { return volume_case([](ffseg_volume& v) { v.offset = INT64_MAX; }); },
       FFSEG_ERR_INVALID_VOLUME, "past the end"},
      {"volume: offset INT64_MIN", [] { return volume_case([](ffseg_volume& v) { v.offset = INT64_MIN; }); },
       FFSEG_ERR_INVALID_VOLUME, "before the start"},
      {"volume: flipped k with offset one byte short", [] {
         return volume_case([](ffseg_volume& v) { v.strides[2] = -v.strides[2]; v.offset = -v.strides[2] * 11 - 1; });
       }, FFSEG_ERR_INVALID_VOLUME, "before the start"},
      {"volume: flipped k with offset one voxel too far", [] {
         return volume_case([](ffseg_volume& v) { v.strides[2] = -v.strides[2]; v.offset = -v.strides[2] * 12; });
       }, FFSEG_ERR_INVALID_VOLUME, "past the end"},
      {"volume: data_bytes 0", [] { return volume_case([](ffseg_volume& v) { v.data_bytes = 0; }); },
       FFSEG_ERR_INVALID_VOLUME, "past the end"},
      {"volume: strides[2] == strides[1]", [] { return volume_case([](ffseg_volume& v) { v.strides[2] = v.strides[1]; }); },
       FFSEG_ERR_INVALID_VOLUME, "alias"},
      {"volume: |negative stride| below the voxel size", [] {
         return volume_case([](ffseg_volume& v) { v.strides[0] = -1; v.offset = 9; });
       }, FFSEG_ERR_INVALID_VOLUME, "alias"},
      {"volume: voxel_type 0x80000001", [] { return volume_case([](ffseg_volume& v) { v.voxel_type = 0x80000001u; }); },
       FFSEG_ERR_INVALID_VOLUME, "voxel_type"},
      {"volume: struct_size 0", [] { return volume_case([](ffseg_volume& v) { v.struct_size = 0; }); },
       FFSEG_ERR_STRUCT_SIZE, "struct_size"},
      {"volume: affine last row 0 0 0 2", [] { return volume_case([](ffseg_volume& v) { v.index_to_world[15] = 2; }); },
       FFSEG_ERR_INVALID_VOLUME, "last row"},
      {"volume: affine -Inf translation", [] { return volume_case([](ffseg_volume& v) { v.index_to_world[11] = -INFINITY; }); },
       FFSEG_ERR_INVALID_VOLUME, "non-finite"},
      {"volume: affine all zero", [] {
         return volume_case([](ffseg_volume& v) { for (int q = 0; q < 12; ++q) v.index_to_world[q] = 0; });
       }, FFSEG_ERR_INVALID_VOLUME, "singular"},
      {"volume: affine columns parallel to 1e-15", [] {
         return volume_case([](ffseg_volume& v) { v.index_to_world[1] = 1; v.index_to_world[5] = 1e-15; });
       }, FFSEG_ERR_INVALID_VOLUME, "singular"},
      {"volume: slope -Inf", [] { return volume_case([](ffseg_volume& v) { v.rescale_slope = -INFINITY; }); },
       FFSEG_ERR_INVALID_VOLUME, "slope"},
      {"volume: intercept NaN", [] { return volume_case([](ffseg_volume& v) { v.rescale_intercept = NAN; }); },
       FFSEG_ERR_INVALID_VOLUME, "intercept"},
      {"volume: slope -0.0", [] { return volume_case([](ffseg_volume& v) { v.rescale_slope = -0.0; }); },
       FFSEG_ERR_INVALID_VOLUME, "slope"},

      // ---- the NIfTI reader (beyond test_nifti's 56) ----
      {"nifti: dim[0] = -1", [] { Bytes b = good_nifti(); put<int16_t>(b, kDim, -1); return read_nifti(b); },
       kReaderRefused, "dim[0] = -1 out of range"},
      {"nifti: dim[3] = 32767 beyond the data", [] { Bytes b = good_nifti(); put<int16_t>(b, kDim + 6, 32767); return read_nifti(b); },
       kReaderRefused, "voxel data truncated"},
      {"nifti: datatype 0 (unknown)", [] { Bytes b = good_nifti(); put<int16_t>(b, kDatatype, 0); return read_nifti(b); },
       kReaderRefused, "datatype 0"},
      {"nifti: bitpix 0", [] { Bytes b = good_nifti(); put<int16_t>(b, kBitpix, 0); return read_nifti(b); },
       kReaderRefused, "bitpix 0 does not match"},
      {"nifti: float64 with bitpix 32", [] {
         Bytes b = good_nifti(ffseg_tools::kNiftiVoxF64); put<int16_t>(b, kBitpix, 32); return read_nifti(b);
       }, kReaderRefused, "bitpix 32 does not match"},
      {"nifti: vox_offset -352", [] { Bytes b = good_nifti(); put<float>(b, kVoxOffset, -352.0f); return read_nifti(b); },
       kReaderRefused, "vox_offset"},
      {"nifti: vox_offset +Inf", [] { Bytes b = good_nifti(); put<float>(b, kVoxOffset, INFINITY); return read_nifti(b); },
       kReaderRefused, "vox_offset is not finite"},
      {"nifti: sform_code 6", [] { Bytes b = good_nifti(); put<int16_t>(b, kSformCode, 6); return read_nifti(b); },
       kReaderRefused, "sform_code 6 out of range"},
      {"nifti: qform_code -1", [] { Bytes b = good_nifti(); put<int16_t>(b, kQformCode, -1); return read_nifti(b); },
       kReaderRefused, "qform_code -1 out of range"},
      {"nifti: scl_slope +Inf", [] { Bytes b = good_nifti(); put<float>(b, kSclSlope, INFINITY); return read_nifti(b); },
       kReaderRefused, "scl_slope is not finite"},
      {"nifti: srow_z translation -Inf", [] { Bytes b = good_nifti(); put<float>(b, kSrow + 32 + 12, -INFINITY); return read_nifti(b); },
       kReaderRefused, "srow_z is not finite"},
      {"nifti: sform with zero pixdim is fine but sform singular", [] {
         Bytes b = good_nifti(); put<float>(b, kPixdim + 4, 0.0f); put<float>(b, kSrow + 8, 0.0f); put<float>(b, kSrow + 16 + 8, 0.0f);
         put<float>(b, kSrow + 32 + 8, 0.0f); return read_nifti(b);
       }, kReaderRefused, "sform is singular"},
      {"nifti: gzip magic only", [] { return read_nifti(Bytes{0x1f, 0x8b}); }, kReaderRefused, "gzip"},
      {"nifti: gzip cut in the voxel data", [] {
         Bytes z = gzip(good_nifti()); z.resize(z.size() / 2 + 10); return read_nifti(z);
       }, kReaderRefused, "gzip stream truncated"},
      {"nifti: 348 zero bytes", [] { return read_nifti(Bytes(348, 0)); }, kReaderRefused, "sizeof_hdr"},

      // ---- call order and misuse ----
      {"calls: step before set_volume", [] { return call_case(Stage::created, [](ffseg_engine* e) { return ffseg_step(e, nullptr); }); },
       FFSEG_ERR_MISUSE, "no volume set"},
      {"calls: init_sphere before set_volume", [] {
         return call_case(Stage::created, [](ffseg_engine* e) { const double c[3] = {16, 16, 16}; return ffseg_init_sphere(e, 0, c, 5); });
       }, FFSEG_ERR_MISUSE, "no volume set"},
      {"calls: step before init_sphere", [] { return call_case(Stage::volume, [](ffseg_engine* e) { return ffseg_step(e, nullptr); }); },
       FFSEG_ERR_MISUSE, "no object placed"},
      {"calls: extract before init_sphere", [] {
         return call_case(Stage::volume, [](ffseg_engine* e) { size_t a, b; return ffseg_extract_mesh(e, 0, nullptr, 0, nullptr, 0, &a, &b); });
       }, FFSEG_ERR_MISUSE, "has no mesh yet"},
      {"calls: rasterize without a volume", [] {
         return call_case(Stage::created, [](ffseg_engine* e) { uint8_t m[8]; return ffseg_rasterize(e, 0, m, nullptr); });
       }, FFSEG_ERR_MISUSE, "no volume set"},
      {"calls: rasterize before init_sphere", [] {
         return call_case(Stage::volume, [](ffseg_engine* e) { std::vector<uint8_t> m(size_t(kN) * kN * kN); return ffseg_rasterize(e, 1, m.data(), nullptr); });
       }, FFSEG_ERR_MISUSE, "has no mesh yet"},
      {"calls: sample without a volume", [] {
         return call_case(Stage::created, [](ffseg_engine* e) { const double p[3] = {0, 0, 0}; double v; return ffseg_sample(e, p, 0, &v); });
       }, FFSEG_ERR_MISUSE, ""},
      {"calls: set_volume after destroy", [] {
         return call_case(Stage::destroyed, [](ffseg_engine* e) {
           const std::vector<uint8_t> d(8, 0); const int64_t dims[3] = {2, 2, 2};
           const ffseg_volume v = make_volume(d.data(), FFSEG_U8, dims, kIdentity); return ffseg_set_volume(e, &v);
         });
       }, FFSEG_ERR_MISUSE, "not a live ffseg engine"},
      {"calls: step after destroy", [] { return call_case(Stage::destroyed, [](ffseg_engine* e) { return ffseg_step(e, nullptr); }); },
       FFSEG_ERR_MISUSE, "not a live ffseg engine"},
      {"calls: extract after destroy", [] {
         return call_case(Stage::destroyed, [](ffseg_engine* e) { size_t a, b; return ffseg_extract_mesh(e, 0, nullptr, 0, nullptr, 0, &a, &b); });
       }, FFSEG_ERR_MISUSE, "not a live ffseg engine"},
      {"calls: init_sphere object UINT32_MAX", [] {
         return call_case(Stage::volume, [](ffseg_engine* e) { const double c[3] = {16, 16, 16}; return ffseg_init_sphere(e, UINT32_MAX, c, 5); });
       }, FFSEG_ERR_OBJECT_OUT_OF_RANGE, "not below max_objects = 2"},
      {"calls: extract object 2 of 2", [] {
         return call_case(Stage::sphere, [](ffseg_engine* e) { size_t a, b; return ffseg_extract_mesh(e, 2, nullptr, 0, nullptr, 0, &a, &b); });
       }, FFSEG_ERR_OBJECT_OUT_OF_RANGE, "not below max_objects"},
      {"calls: rasterize object 7 of 2", [] {
         return call_case(Stage::sphere, [](ffseg_engine* e) { std::vector<uint8_t> m(size_t(kN) * kN * kN); return ffseg_rasterize(e, 7, m.data(), nullptr); });
       }, FFSEG_ERR_OBJECT_OUT_OF_RANGE, "not below max_objects"},
      {"calls: extract into a buffer one triangle short", [] {
         return call_case(Stage::sphere, [](ffseg_engine* e) {
           std::vector<float> x(3 * 96); std::vector<uint32_t> t(3 * 187); size_t a, b;
           return ffseg_extract_mesh(e, 0, x.data(), 96, t.data(), 187, &a, &b);
         });
       }, FFSEG_ERR_BUFFER_TOO_SMALL, "the mesh has 96 and 188"},
      {"calls: step_info.struct_size 0", [] {
         return call_case(Stage::sphere, [](ffseg_engine* e) { ffseg_step_info i; std::memset(&i, 0, sizeof i); return ffseg_step(e, &i); });
       }, FFSEG_ERR_STRUCT_SIZE, "step_info.struct_size"},
      {"calls: init_sphere radius 1e31 (beyond float)", [] {
         return call_case(Stage::volume, [](ffseg_engine* e) { const double c[3] = {16, 16, 16}; return ffseg_init_sphere(e, 0, c, 1e31); });
       }, FFSEG_ERR_INVALID_ARGUMENT, "1e30"},
      {"calls: init_sphere centre -Inf", [] {
         return call_case(Stage::volume, [](ffseg_engine* e) { const double c[3] = {16, -INFINITY, 16}; return ffseg_init_sphere(e, 0, c, 5); });
       }, FFSEG_ERR_INVALID_ARGUMENT, "centre must be finite"},
      {"calls: init_sphere far outside", [] {
         return call_case(Stage::volume, [](ffseg_engine* e) { const double c[3] = {1e6, 16, 16}; return ffseg_init_sphere(e, 0, c, 5); });
       }, FFSEG_ERR_SPHERE_OUTSIDE, "does not meet the volume"},

      // ---- parameters: every field out of range names it (step_size and flip_tau are in test_api_contract) ----
      {"params: target_mode 2", [] { return params_case([](ffseg_params& p) { p.target_mode = 2; }); }, FFSEG_ERR_INVALID_ARGUMENT, "target_mode"},
      {"params: lambda_laplacian 0", [] { return params_case([](ffseg_params& p) { p.lambda_laplacian = 0; }); }, FFSEG_ERR_INVALID_ARGUMENT, "lambda_laplacian"},
      {"params: lambda_position NaN", [] { return params_case([](ffseg_params& p) { p.lambda_position = NAN; }); }, FFSEG_ERR_INVALID_ARGUMENT, "lambda_position"},
      // The smallest denormal once passed (0, 1e6] and its anchor weight rounded to 0: NaN vertices (fuzz_calls, 2026-12-04).
      {"params: lambda_position 4.9e-324", [] { return params_case([](ffseg_params& p) { p.lambda_position = 4.9406564584124654e-324; }); }, FFSEG_ERR_INVALID_ARGUMENT, "lambda_position = 4.94066e-324 is outside [1e-6, 1e6]"},
      {"params: lambda_position 1e-7", [] { return params_case([](ffseg_params& p) { p.lambda_position = 1e-7; }); }, FFSEG_ERR_INVALID_ARGUMENT, "lambda_position"},
      {"params: lambda_uniform -1", [] { return params_case([](ffseg_params& p) { p.lambda_uniform = -1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "lambda_uniform"},
      {"params: lambda_laplacian 1e6 + 1", [] { return params_case([](ffseg_params& p) { p.lambda_laplacian = 1e6 + 1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "lambda_laplacian"},
      {"params: step_size Inf", [] { return params_case([](ffseg_params& p) { p.step_size = INFINITY; }); }, FFSEG_ERR_INVALID_ARGUMENT, "step_size"},
      {"params: flip_tau 1", [] { return params_case([](ffseg_params& p) { p.flip_tau = 1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "flip_tau"},
      {"params: search_range_mm -1", [] { return params_case([](ffseg_params& p) { p.search_range_mm = -1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "search_range_mm"},
      {"params: search_step_mm 101", [] { return params_case([](ffseg_params& p) { p.search_step_mm = 101; }); }, FFSEG_ERR_INVALID_ARGUMENT, "search_step_mm"},
      {"params: convergence_mm -1", [] { return params_case([](ffseg_params& p) { p.convergence_mm = -1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "convergence_mm"},
      {"params: diffusion_iterations 101", [] { return params_case([](ffseg_params& p) { p.diffusion_iterations = 101; }); }, FFSEG_ERR_INVALID_ARGUMENT, "diffusion_iterations"},
      {"params: consecutive_background 0", [] { return params_case([](ffseg_params& p) { p.consecutive_background = 0; }); }, FFSEG_ERR_INVALID_ARGUMENT, "consecutive_background"},
      {"params: consecutive_background 65", [] { return params_case([](ffseg_params& p) { p.consecutive_background = 65; }); }, FFSEG_ERR_INVALID_ARGUMENT, "consecutive_background"},
      {"params: struct_size 0", [] { return params_case([](ffseg_params& p) { p.struct_size = 0; }); }, FFSEG_ERR_STRUCT_SIZE, "params.struct_size"},

      // ---- configuration ----
      {"config: reserved0 = 1", [] { return config_case([](ffseg_config& c) { c.reserved0 = 1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "reserved0"},
      {"config: max_objects 65", [] { return config_case([](ffseg_config& c) { c.max_objects = 65; }); }, FFSEG_ERR_INVALID_ARGUMENT, "max_objects"},
      {"config: mesh_resolution 1025", [] { return config_case([](ffseg_config& c) { c.mesh_resolution = 1025; }); }, FFSEG_ERR_INVALID_ARGUMENT, "mesh_resolution"},
      {"config: max_roi_voxels 2^40 + 1", [] { return config_case([](ffseg_config& c) { c.max_roi_voxels = (int64_t(1) << 40) + 1; }); }, FFSEG_ERR_INVALID_ARGUMENT, "max_roi_voxels"},
      {"config: struct_size 0", [] { return config_case([](ffseg_config& c) { c.struct_size = 0; }); }, FFSEG_ERR_STRUCT_SIZE, "struct_size"},
  };
  return t;
}

}  // namespace

TEST_CASE("robustness: named malformed inputs and misuse get the documented status and message") {
  const std::vector<Case> cases = malformed_cases();
  CHECK(cases.size() >= 40);
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const Outcome o = c.run();
    CHECK_MESSAGE(o.status == c.status, c.name, ": status ", o.status, ", expected ", c.status, " (", o.msg, ")");
    CHECK_MESSAGE(o.msg.find(c.msg) != std::string::npos, c.name, ": got \"", o.msg, "\", expected \"", c.msg, "\"");
  }
}

TEST_CASE("robustness: every refused call leaves the engine usable and its state unchanged") {
  const std::vector<uint8_t> data = ball_u8(15.5, 16, 16.5, 8);
  const ffseg_volume v = volume32(data, kAniso);
  double c[3];
  const double ijk[3] = {16, 16, 16};
  for (int r = 0; r < 3; ++r) c[r] = kAniso[4 * r] * ijk[0] + kAniso[4 * r + 1] * ijk[1] + kAniso[4 * r + 2] * ijk[2] + kAniso[4 * r + 3];
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.step_size = 0.8;
  p.diffusion_iterations = 3;

  EngineBox ref(1, 8);
  REQUIRE(ref.e != nullptr);
  const std::vector<float> expect = segment(ref.e, v, c, 5, 6, &p);

  // Same run, with refused calls interleaved everywhere.
  EngineBox eb(1, 8);
  REQUIRE(eb.e != nullptr);
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_params bad = p;
  bad.search_range_mm = NAN;
  CHECK(ffseg_set_params(eb.e, &bad) == FFSEG_ERR_INVALID_ARGUMENT);  // previous params stay
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  ffseg_volume broken = v;
  broken.data_bytes -= 1;
  CHECK(ffseg_set_volume(eb.e, &broken) == FFSEG_ERR_INVALID_VOLUME);  // previous volume stays
  CHECK(ffseg_init_sphere(eb.e, 0, c, -1) == FFSEG_ERR_INVALID_ARGUMENT);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, 5) == FFSEG_OK);
  const double far[3] = {1e5, 0, 0};
  CHECK(ffseg_init_sphere(eb.e, 0, far, 1) == FFSEG_ERR_SPHERE_OUTSIDE);  // the mesh stays
  CHECK(ffseg_init_sphere(eb.e, 3, c, 5) == FFSEG_ERR_OBJECT_OUT_OF_RANGE);
  for (int s = 0; s < 6; ++s) {
    ffseg_step_info info;
    std::memset(&info, 0, sizeof info);
    CHECK(ffseg_step(eb.e, &info) == FFSEG_ERR_STRUCT_SIZE);  // refused before any work
    bad = p;
    bad.diffusion_iterations = 1000;
    CHECK(ffseg_set_params(eb.e, &bad) == FFSEG_ERR_INVALID_ARGUMENT);
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    REQUIRE((st == FFSEG_OK || st == FFSEG_CONVERGED));
    float tiny[3];
    size_t nv = 0, nt = 0;
    CHECK(ffseg_extract_mesh(eb.e, 0, tiny, 1, nullptr, 0, &nv, &nt) == FFSEG_ERR_BUFFER_TOO_SMALL);
  }
  std::vector<float> got;
  std::vector<uint32_t> tris;
  REQUIRE(ffseg_test::extract(eb.e, 0, &got, &tris));
  CHECK(same_bits(got, expect));
}

TEST_CASE("robustness: workspace sweep from 0 bytes to the exact size") {
  struct Cfg {
    uint32_t objects, n;
  };
  for (const Cfg& k : {Cfg{1, 2}, Cfg{1, 8}, Cfg{3, 5}, Cfg{1, 33}}) {
    CAPTURE(k.objects);
    CAPTURE(k.n);
    ffseg_config cfg;
    ffseg_config_init_default(&cfg);
    cfg.max_objects = k.objects;
    cfg.mesh_resolution = k.n;
    size_t need = 0;
    REQUIRE(ffseg_workspace_size(&cfg, &need) == FFSEG_OK);
    REQUIRE(need % 64 == 0);
    // Room for the sweep plus a guard zone that must never be written.
    const size_t guard = 256;
    unsigned char* mem = static_cast<unsigned char*>(std::aligned_alloc(64, need + guard));
    REQUIRE(mem != nullptr);
    std::vector<size_t> sizes = {0, 1, 63, 64, 65, 128, need / 2, need - 64, need - 63, need - 1};
    for (int s = 1; s < 32; ++s) sizes.push_back(need / 32 * size_t(s));
    const std::string need_text = std::to_string(need);
    for (size_t bytes : sizes) {
      if (bytes >= need) continue;
      CAPTURE(bytes);
      std::memset(mem, 0xA5, need + guard);
      ffseg_engine* e = reinterpret_cast<ffseg_engine*>(mem + 1);
      CHECK(ffseg_create(&cfg, mem, bytes, &e) == FFSEG_ERR_WORKSPACE_TOO_SMALL);
      CHECK(e == nullptr);
      CHECK(std::string(ffseg_last_error(nullptr)).find(need_text) != std::string::npos);
      // Nothing at or beyond the bytes handed over was touched.
      size_t touched = 0;
      for (size_t q = bytes; q < need + guard; ++q) touched += mem[q] != 0xA5;
      CHECK(touched == 0);
    }
    // The boundary: exactly `need` succeeds and stays inside it; more is fine.
    for (size_t bytes : {need, need + 1, need + 64}) {
      CAPTURE(bytes);
      std::memset(mem, 0xA5, need + guard);
      ffseg_engine* e = nullptr;
      REQUIRE(ffseg_create(&cfg, mem, bytes, &e) == FFSEG_OK);
      REQUIRE(e != nullptr);
      size_t touched = 0;
      for (size_t q = need; q < need + guard; ++q) touched += mem[q] != 0xA5;
      CHECK(touched == 0);
      const std::vector<uint8_t> data = ball_u8(15.5, 16, 16.5, 8);
      const ffseg_volume v = volume32(data);
      const double c[3] = {16, 16, 16};
      REQUIRE(ffseg_set_volume(e, &v) == FFSEG_OK);
      REQUIRE(ffseg_init_sphere(e, k.objects - 1, c, 5) == FFSEG_OK);
      const ffseg_status st = ffseg_step(e, nullptr);
      CHECK((st == FFSEG_OK || st == FFSEG_CONVERGED));
      touched = 0;
      for (size_t q = need; q < need + guard; ++q) touched += mem[q] != 0xA5;
      CHECK(touched == 0);
      ffseg_destroy(e);
    }
    std::free(mem);
  }
}

TEST_CASE("determinism: the same inputs give bit-identical meshes, whatever the workspace held before") {
  const std::vector<uint8_t> data = ball_u8(14.5, 17, 16, 9);
  const ffseg_volume v = volume32(data, kAniso);
  const double c[3] = {0, 21, 14};
  ffseg_config cfg;
  ffseg_config_init_default(&cfg);
  cfg.mesh_resolution = 10;
  size_t need = 0;
  REQUIRE(ffseg_workspace_size(&cfg, &need) == FFSEG_OK);
  std::vector<float> first;
  for (int run = 0; run < 3; ++run) {
    CAPTURE(run);
    void* ws = std::aligned_alloc(64, need);
    REQUIRE(ws != nullptr);
    std::memset(ws, run == 1 ? 0xFF : 0x00, need);  // stale bytes must not matter
    ffseg_engine* e = nullptr;
    REQUIRE(ffseg_create(&cfg, ws, need, &e) == FFSEG_OK);
    const std::vector<float> xyz = segment(e, v, c, 6, 8);
    if (run == 0) first = xyz;
    else CHECK(same_bits(xyz, first));
    // Destroy and re-create in the same (now dirty) workspace: same answer.
    ffseg_destroy(e);
    REQUIRE(ffseg_create(&cfg, ws, need, &e) == FFSEG_OK);
    CHECK(same_bits(segment(e, v, c, 6, 8), first));
    ffseg_destroy(e);
    std::free(ws);
  }
}

TEST_CASE("threads: two engines stepping in two threads give the meshes of one after the other") {
  const std::vector<uint8_t> a_data = ball_u8(15.5, 16, 16.5, 8);
  const std::vector<uint8_t> b_data = ball_u8(12, 18, 15, 10);
  const ffseg_volume va = volume32(a_data, kIdentity);
  const ffseg_volume vb = volume32(b_data, kAniso);
  const double ca[3] = {16, 16, 16};
  const double cb[3] = {-4.5, 22, 13};
  ffseg_params pb;
  ffseg_params_init_default(&pb);
  pb.step_size = 0.7;
  const int steps = 8;

  std::vector<float> seq_a, seq_b;
  {
    EngineBox ea(1, 10), eb(1, 10);
    REQUIRE(ea.e != nullptr);
    REQUIRE(eb.e != nullptr);
    seq_a = segment(ea.e, va, ca, 5, steps);
    seq_b = segment(eb.e, vb, cb, 6, steps, &pb);
  }
  for (int round = 0; round < 2; ++round) {
    CAPTURE(round);
    EngineBox ea(1, 10), eb(1, 10);
    REQUIRE(ea.e != nullptr);
    REQUIRE(eb.e != nullptr);
    std::vector<float> par_a, par_b;
    // No doctest assertions inside the threads (doctest is not thread-safe
    // there); each thread records its statuses.
    auto run = [steps](ffseg_engine* e, const ffseg_volume* v, const double* c, double r, const ffseg_params* p,
                       std::vector<float>* out, bool* ok) {
      *ok = (p == nullptr || ffseg_set_params(e, p) == FFSEG_OK) && ffseg_set_volume(e, v) == FFSEG_OK &&
            ffseg_init_sphere(e, 0, c, r) == FFSEG_OK;
      for (int s = 0; s < steps && *ok; ++s) {
        const ffseg_status st = ffseg_step(e, nullptr);
        *ok = st == FFSEG_OK || st == FFSEG_CONVERGED;
      }
      size_t nv = 0, nt = 0;
      *ok = *ok && ffseg_extract_mesh(e, 0, nullptr, 0, nullptr, 0, &nv, &nt) == FFSEG_OK;
      if (!*ok) return;
      out->resize(3 * nv);
      *ok = ffseg_extract_mesh(e, 0, out->data(), nv, nullptr, 0, &nv, &nt) == FFSEG_OK;
    };
    bool ok_a = false, ok_b = false;
    std::thread ta(run, ea.e, &va, ca, 5.0, nullptr, &par_a, &ok_a);
    std::thread tb(run, eb.e, &vb, cb, 6.0, &pb, &par_b, &ok_b);
    ta.join();
    tb.join();
    REQUIRE(ok_a);
    REQUIRE(ok_b);
    CHECK(same_bits(par_a, seq_a));
    CHECK(same_bits(par_b, seq_b));
  }
  // Per-thread messages of engine-less calls do not leak across threads.
  ffseg_config bad;
  ffseg_config_init_default(&bad);
  bad.max_objects = 0;
  size_t bytes = 0;
  REQUIRE(ffseg_workspace_size(&bad, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  std::string other;
  std::thread t([&other] { other = ffseg_last_error(nullptr); });
  t.join();
  CHECK(other.empty());
  CHECK(std::string(ffseg_last_error(nullptr)).find("max_objects") != std::string::npos);
}

// ---- the fuzzers' findings ------------------------------------------------------------

TEST_CASE("fuzz regression (calls): a tiny search_step_mm does not overflow the sample count") {
  // fuzz_calls found: params.search_step_mm = 1e-300 (inside its documented
  // [0, 100]) made ceil(search_range_mm / search_step_mm) overflow int in the
  // correspondence search (UBSan: float-cast-overflow). The same happens with
  // search_step_mm = 0 on a volume whose voxels are 1e-100 mm.
  const std::vector<uint8_t> data = ball_u8(15.5, 16, 16.5, 8);
  for (int variant = 0; variant < 2; ++variant) {
    CAPTURE(variant);
    EngineBox eb(1, 4);
    REQUIRE(eb.e != nullptr);
    ffseg_params p;
    ffseg_params_init_default(&p);
    double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (variant == 0) {
      p.search_step_mm = 1e-300;
      p.search_range_mm = 1e4;
    } else {
      for (int d = 0; d < 3; ++d) A[5 * d] = 1e-100;
    }
    REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
    const ffseg_volume v = volume32(data, A);
    REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
    const double c[3] = {16 * A[0], 16 * A[5], 16 * A[10]};
    REQUIRE(ffseg_init_sphere(eb.e, 0, c, 5 * A[0]) == FFSEG_OK);
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    CHECK((st == FFSEG_OK || st == FFSEG_CONVERGED || st == FFSEG_ERR_NUMERIC));
    std::vector<float> xyz;
    std::vector<uint32_t> tris;
    REQUIRE(ffseg_test::extract(eb.e, 0, &xyz, &tris));
    for (float f : xyz) REQUIRE(std::isfinite(f));
  }
}

TEST_CASE("fuzz regression (calls): a sphere beyond float range is refused, not extracted as infinities") {
  // fuzz_calls found: init_sphere(centre -0,-0,-0, radius 1e300) was accepted
  // (the ball contains the grid) and extract_mesh returned +-Inf floats.
  const std::vector<uint8_t> data = ball_u8(15.5, 16, 16.5, 8);
  EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  const ffseg_volume v = volume32(data);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double z[3] = {-0.0, -0.0, -0.0};
  CHECK(ffseg_init_sphere(eb.e, 0, z, 1e300) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::string(ffseg_last_error(eb.e)).find("1e30") != std::string::npos);
  const double big[3] = {-2e30, 0, 0};
  CHECK(ffseg_init_sphere(eb.e, 0, big, 1) == FFSEG_ERR_INVALID_ARGUMENT);
  // Large but representable spheres are still fine, and extract finite.
  REQUIRE(ffseg_init_sphere(eb.e, 0, z, 1e20) == FFSEG_OK);
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  REQUIRE(ffseg_test::extract(eb.e, 0, &xyz, &tris));
  for (float f : xyz) REQUIRE(std::isfinite(f));
  // Precedence is unchanged: a bad object index is still reported as such.
  CHECK(ffseg_init_sphere(eb.e, 9, z, 1e300) == FFSEG_ERR_OBJECT_OUT_OF_RANGE);
}

TEST_CASE("fuzz regression (nifti): a strongly anisotropic sform accepted by the reader is accepted by the engine") {
  // fuzz_nifti found (input: fuzz/corpus/nifti/regress_anisotropic_sform.nii): an sform with voxel edges
  // 0.75, 1.5 and 3.2e8 mm. The reader accepted it (|det| against the product
  // of the column norms); the engine refused it as singular because it
  // compared |det| with the largest row norm cubed, which is not invariant to
  // anisotropic spacing. The engine now uses the column norms as well.
  // The exact input is a seed of the nifti fuzzer: read it from there.
  {
    const std::string path = std::string(FFSEG_SOURCE_DIR) + "/fuzz/corpus/nifti/regress_anisotropic_sform.nii";
    ffseg_tools::NiftiImage img;
    std::string err;
    REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(path, &img, &err), err);
    const int64_t dims[3] = {img.dims[0], img.dims[1], img.dims[2]};
    ffseg_volume v = make_volume(img.data.data(), uint32_t(img.voxel_type), dims, img.index_to_world);
    v.rescale_slope = img.scl_slope;
    v.rescale_intercept = img.scl_inter;
    EngineBox eb(1, 4);
    REQUIRE(eb.e != nullptr);
    CHECK_MESSAGE(ffseg_set_volume(eb.e, &v) == FFSEG_OK, ffseg_last_error(eb.e));
  }
  // The same sform rebuilt from its fields.
  ffseg_tools::NiftiImage img;
  img.dims[0] = 4;
  img.dims[1] = 3;
  img.dims[2] = 2;
  img.voxel_type = ffseg_tools::kNiftiVoxU8;
  img.bytes_per_voxel = 1;
  img.data.assign(24, 1);
  const double A[16] = {0, -1.2000000476837158, -322122560.0, 10.0, 0.75, 0, 0, -20.0,
                        0, 0.8999999761581421, 8.673617509131006e-20, 5.0, 0, 0, 0, 1};
  std::memcpy(img.index_to_world, A, sizeof A);
  img.sform_code = 1;
  img.qform_code = 0;
  Bytes file;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_encode(img, false, &file, &err), err);
  ffseg_tools::NiftiImage back;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_memory(file.data(), file.size(), &back, &err), err);
  const int64_t dims[3] = {back.dims[0], back.dims[1], back.dims[2]};
  const ffseg_volume v = make_volume(back.data.data(), FFSEG_U8, dims, back.index_to_world);
  EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  CHECK_MESSAGE(ffseg_set_volume(eb.e, &v) == FFSEG_OK, ffseg_last_error(eb.e));
  // Spacings from 1e-4 to 1e4 mm in one volume are fine too; truly degenerate frames are not.
  std::vector<uint8_t> d(8, 0);
  const int64_t d2[3] = {2, 2, 2};
  const double wide[16] = {1e-4, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1e4, 0, 0, 0, 0, 1};
  const ffseg_volume vw = make_volume(d.data(), FFSEG_U8, d2, wide);
  CHECK(ffseg_set_volume(eb.e, &vw) == FFSEG_OK);
  const double flat[16] = {1, 1, 0, 0, 0, 1e-13, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const ffseg_volume vf = make_volume(d.data(), FFSEG_U8, d2, flat);
  CHECK(ffseg_set_volume(eb.e, &vf) == FFSEG_ERR_INVALID_VOLUME);
}

TEST_CASE("fuzz regression (volume): a grey-level sphere holding no voxel centre is SPHERE_OUTSIDE at the step, mesh unchanged") {
  // fuzz_volume found (once grey-level targets joined it): init_sphere accepts
  // a 0.25 mm sphere between voxel centres (the ball meets the grid), and the
  // first grey-level step returns SPHERE_OUTSIDE, which ffseg.h did not list
  // among ffseg_step's errors (now it does). The mesh must stay the sphere and
  // the engine usable.
  const std::vector<uint8_t> data = ball_u8(15.5, 16, 16.5, 8);
  EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  const ffseg_volume v = volume32(data);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double between[3] = {15.5, 16.5, 16.5};  // 0.71 mm or more from every centre
  REQUIRE(ffseg_init_sphere(eb.e, 0, between, 0.25) == FFSEG_OK);
  std::vector<float> sphere, after;
  std::vector<uint32_t> tris;
  REQUIRE(ffseg_test::extract(eb.e, 0, &sphere, &tris));
  CHECK(ffseg_step(eb.e, nullptr) == FFSEG_ERR_SPHERE_OUTSIDE);
  CHECK(std::string(ffseg_last_error(eb.e)).find("sphere") != std::string::npos);
  REQUIRE(ffseg_test::extract(eb.e, 0, &after, &tris));
  CHECK(same_bits(after, sphere));
  // A sphere that holds voxel centres segments as usual.
  const double centre[3] = {15.5, 16, 16.5};
  REQUIRE(ffseg_init_sphere(eb.e, 0, centre, 4) == FFSEG_OK);
  const ffseg_status st = ffseg_step(eb.e, nullptr);
  CHECK((st == FFSEG_OK || st == FFSEG_CONVERGED));
}

TEST_CASE("fuzz regression (volume): grey levels beyond float range are NUMERIC at the grey-level step, mesh unchanged") {
  // fuzz_volume found (fuzz/corpus/volume/regress_grey_beyond_float): an f64
  // volume with values near 1e289 is accepted (finite), the grey-level crop is
  // float, so its noise estimate and range overflow, and the first grey-level
  // step returned INVALID_ARGUMENT ("binning radius/separation and sigma
  // floor must be finite"), which ffseg_step does not document. Now NUMERIC
  // with a message; mesh unchanged, the engine usable.
  const int N = 8;
  std::vector<double> vox(size_t(N) * N * N);
  for (size_t q = 0; q < vox.size(); ++q) vox[q] = double((q * 7919) % 3) * 1e39;
  ffseg_volume v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.voxel_type = FFSEG_F64;
  v.data = vox.data();
  v.data_bytes = vox.size() * sizeof(double);
  for (int a = 0; a < 3; ++a) v.dims[a] = N;
  v.strides[0] = 8;
  v.strides[1] = 8 * N;
  v.strides[2] = 8 * N * N;
  v.index_to_world[0] = v.index_to_world[5] = v.index_to_world[10] = v.index_to_world[15] = 1;
  v.rescale_slope = 1;
  EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double centre[3] = {3.5, 3.5, 3.5};
  REQUIRE(ffseg_init_sphere(eb.e, 0, centre, 2.0) == FFSEG_OK);
  std::vector<float> sphere, after;
  std::vector<uint32_t> tris;
  REQUIRE(ffseg_test::extract(eb.e, 0, &sphere, &tris));
  CHECK(ffseg_step(eb.e, nullptr) == FFSEG_ERR_NUMERIC);
  CHECK(std::string(ffseg_last_error(eb.e)).find("not finite") != std::string::npos);
  REQUIRE(ffseg_test::extract(eb.e, 0, &after, &tris));
  CHECK(same_bits(after, sphere));
  // Binary targets on the same volume segment as usual.
  p.target_mode = FFSEG_TARGET_BINARY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  const ffseg_status st = ffseg_step(eb.e, nullptr);
  CHECK((st == FFSEG_OK || st == FFSEG_CONVERGED));
}
