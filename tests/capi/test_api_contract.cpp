// The C API's contract (include/ffseg.h): the workspace, config and params
// validation, the volume view's validation and sampling, init_sphere and
// extract_mesh errors.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstddef>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cubesphere.h"
#include "ffseg.h"
#include "support/mesh_box.h"
#include "test_util.h"
#include "volume.h"

using ffseg_test::EngineBox;
using ffseg_test::make_volume;

using ffseg_test::MeshBox;

TEST_CASE("workspace: exact size, one byte less fails with the size named, misaligned fails") {
  for (uint32_t n : {2u, 7u, 33u}) {
    for (uint32_t objs : {1u, 3u}) {
      ffseg_config cfg;
      ffseg_config_init_default(&cfg);
      cfg.mesh_resolution = n;
      cfg.max_objects = objs;
      size_t bytes = 0;
      REQUIRE(ffseg_workspace_size(&cfg, &bytes) == FFSEG_OK);
      REQUIRE(bytes > 0);
      void* ws = std::aligned_alloc(64, (bytes + 127) / 64 * 64);
      ffseg_engine* e = reinterpret_cast<ffseg_engine*>(1);
      CHECK(ffseg_create(&cfg, ws, bytes - 1, &e) == FFSEG_ERR_WORKSPACE_TOO_SMALL);
      CHECK(e == nullptr);
      CHECK(std::strstr(ffseg_last_error(nullptr), std::to_string(bytes).c_str()) != nullptr);
      CHECK(ffseg_create(&cfg, static_cast<char*>(ws) + 8, bytes, &e) == FFSEG_ERR_WORKSPACE_MISALIGNED);
      CHECK(ffseg_create(&cfg, nullptr, bytes, &e) == FFSEG_ERR_NULL_POINTER);
      REQUIRE(ffseg_create(&cfg, ws, bytes, &e) == FFSEG_OK);
      REQUIRE(e != nullptr);
      ffseg_destroy(e);
      // The engine is gone: calls on the stale handle are misuse, not crashes.
      CHECK(ffseg_init_sphere(e, 0, nullptr, 1.0) == FFSEG_ERR_MISUSE);
      std::free(ws);
    }
  }
  ffseg_destroy(nullptr);
}

TEST_CASE("config and params are validated, struct_size honoured") {
  ffseg_config cfg;
  ffseg_config_init_default(&cfg);
  size_t bytes = 0;
  CHECK(ffseg_workspace_size(nullptr, &bytes) == FFSEG_ERR_NULL_POINTER);
  CHECK(ffseg_workspace_size(&cfg, nullptr) == FFSEG_ERR_NULL_POINTER);
  ffseg_config bad = cfg;
  bad.max_objects = 0;
  CHECK(ffseg_workspace_size(&bad, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::strstr(ffseg_last_error(nullptr), "max_objects") != nullptr);
  bad = cfg;
  bad.mesh_resolution = 1;
  CHECK(ffseg_workspace_size(&bad, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::strstr(ffseg_last_error(nullptr), "mesh_resolution") != nullptr);
  bad = cfg;
  bad.max_roi_voxels = -5;
  CHECK(ffseg_workspace_size(&bad, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  bad = cfg;
  bad.struct_size = 8;
  CHECK(ffseg_workspace_size(&bad, &bytes) == FFSEG_ERR_STRUCT_SIZE);

  EngineBox eb(1, 8);
  ffseg_params p;
  ffseg_params_init_default(&p);
  CHECK(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_params q = p;
  q.step_size = 0;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::strstr(ffseg_last_error(eb.e), "step_size") != nullptr);
  q = p;
  q.flip_tau = NAN;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::strstr(ffseg_last_error(eb.e), "flip_tau") != nullptr);
  q = p;
  q.partial_volume_steps = 1001;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::strstr(ffseg_last_error(eb.e), "partial_volume_steps") != nullptr);
  // A caller built against the layout before partial_volume_steps: the field
  // lies beyond its struct_size, is not read and keeps its default.
  q.struct_size = uint32_t(offsetof(ffseg_params, partial_volume_steps));
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_OK);
  q = p;
  q.struct_size = 4;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_ERR_STRUCT_SIZE);
  CHECK(ffseg_set_params(eb.e, nullptr) == FFSEG_ERR_NULL_POINTER);
  CHECK(ffseg_set_params(nullptr, &p) == FFSEG_ERR_NULL_POINTER);
  CHECK(std::string(ffseg_status_string(FFSEG_ERR_NUMERIC)) == "numeric failure");
  CHECK(std::string(ffseg_status_string(-999)) == "unknown status");
  CHECK(ffseg_version_number() == FFSEG_VERSION_NUMBER);
}

TEST_CASE("malformed volumes are refused with a message, never read") {
  std::vector<uint16_t> buf(10 * 11 * 12, 1);
  const int64_t dims[3] = {10, 11, 12};
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const ffseg_volume good = make_volume(buf.data(), FFSEG_U16, dims, A);
  EngineBox eb(1, 4);
  REQUIRE(ffseg_set_volume(eb.e, &good) == FFSEG_OK);
  struct Case {
    const char* name;
    void (*edit)(ffseg_volume&);
    const char* msg;
  };
  const Case cases[] = {
      {"zero dim", [](ffseg_volume& v) { v.dims[1] = 0; }, "dims[1]"},
      {"negative dim", [](ffseg_volume& v) { v.dims[2] = -3; }, "dims[2]"},
      {"product overflow", [](ffseg_volume& v) { v.dims[0] = v.dims[1] = v.dims[2] = int64_t(1) << 22; }, "overflow"},
      {"bytes overflow", [](ffseg_volume& v) { v.dims[0] = int64_t(1) << 62; v.dims[1] = v.dims[2] = 1; }, "overflow"},
      {"null data", [](ffseg_volume& v) { v.data = nullptr; }, "NULL"},
      {"unknown type", [](ffseg_volume& v) { v.voxel_type = 9; }, "voxel_type"},
      {"type zero", [](ffseg_volume& v) { v.voxel_type = 0; }, "voxel_type"},
      {"stride past end", [](ffseg_volume& v) { v.strides[2] += 2; }, "past the end"},
      {"short data", [](ffseg_volume& v) { v.data_bytes -= 1; }, "past the end"},
      {"offset before start", [](ffseg_volume& v) { v.offset = -2; }, "before the start"},
      {"negative stride without offset", [](ffseg_volume& v) { v.strides[0] = -2; }, "before the start"},
      {"aliasing zero stride", [](ffseg_volume& v) { v.strides[1] = 0; }, "alias"},
      {"overlapping bytes", [](ffseg_volume& v) { v.strides[0] = 1; }, "alias"},
      {"interleaved axes", [](ffseg_volume& v) { v.strides[1] = 4; }, "alias"},
      {"singular affine", [](ffseg_volume& v) { v.index_to_world[5] = 0; }, "singular"},
      {"rank-deficient affine", [](ffseg_volume& v) { v.index_to_world[4] = 1; v.index_to_world[5] = 0; v.index_to_world[0] = 1; v.index_to_world[1] = 0; v.index_to_world[4] = 1; }, "singular"},
      {"NaN affine", [](ffseg_volume& v) { v.index_to_world[3] = NAN; }, "non-finite"},
      {"Inf affine", [](ffseg_volume& v) { v.index_to_world[0] = INFINITY; }, "non-finite"},
      {"projective last row", [](ffseg_volume& v) { v.index_to_world[12] = 0.5; }, "last row"},
      {"zero slope", [](ffseg_volume& v) { v.rescale_slope = 0; }, "slope"},
      {"NaN slope", [](ffseg_volume& v) { v.rescale_slope = NAN; }, "slope"},
      {"Inf intercept", [](ffseg_volume& v) { v.rescale_intercept = INFINITY; }, "intercept"},
      {"huge stride overflow", [](ffseg_volume& v) { v.strides[2] = INT64_MAX / 4; }, "past the end"},
      {"huge negative stride", [](ffseg_volume& v) { v.strides[2] = INT64_MIN / 4; }, "before the start"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    ffseg_volume v = good;
    c.edit(v);
    CHECK(ffseg_set_volume(eb.e, &v) == FFSEG_ERR_INVALID_VOLUME);
    CHECK(std::strstr(ffseg_last_error(eb.e), c.msg) != nullptr);
  }
  ffseg_volume small = good;
  small.struct_size = 16;
  CHECK(ffseg_set_volume(eb.e, &small) == FFSEG_ERR_STRUCT_SIZE);
  CHECK(ffseg_set_volume(eb.e, nullptr) == FFSEG_ERR_NULL_POINTER);
  // Negative strides with an offset to the last voxel are fine (flipped axes).
  ffseg_volume flipped = good;
  flipped.strides[2] = -good.strides[2];
  flipped.offset = good.strides[2] * (dims[2] - 1);
  CHECK(ffseg_set_volume(eb.e, &flipped) == FFSEG_OK);
  // Padded rows are fine.
  std::vector<uint8_t> padded(size_t(16 * 11 * 12));
  ffseg_volume pv = make_volume(padded.data(), FFSEG_U8, dims, A);
  pv.strides[1] = 16;
  pv.strides[2] = 16 * 11;
  pv.data_bytes = padded.size();
  CHECK(ffseg_set_volume(eb.e, &pv) == FFSEG_OK);
}

TEST_CASE("sampling: nearest and trilinear in world mm under a rotated anisotropic affine") {
  // f(i,j,k) = 3i + 5j - 2k + 7 stored as i32 with slope 0.5, intercept -1:
  // trilinear interpolation of a linear function is exact.
  const int64_t dims[3] = {6, 5, 4};
  std::vector<int32_t> data(6 * 5 * 4);
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 6; ++i) data[size_t(i + 6 * (j + 5 * k))] = 3 * i + 5 * j - 2 * k + 7;
  // Rotation by 90 degrees about x, spacing (0.5, 2, 3), origin (10, -4, 1).
  const double A[16] = {0.5, 0, 0, 10, 0, 0, -3, -4, 0, 2, 0, 1, 0, 0, 0, 1};
  EngineBox eb(1, 4);
  ffseg_volume v = make_volume(data.data(), FFSEG_I32, dims, A);
  v.rescale_slope = 0.5;
  v.rescale_intercept = -1;
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  auto world = [&](double i, double j, double k, double w[3]) {
    for (int r = 0; r < 3; ++r) w[r] = A[4 * r] * i + A[4 * r + 1] * j + A[4 * r + 2] * k + A[4 * r + 3];
  };
  double w[3], val = 0;
  world(2.25, 1.5, 2.75, w);
  REQUIRE(ffseg_sample(eb.e, w, FFSEG_SAMPLE_LINEAR, &val) == FFSEG_OK);
  CHECK(val == doctest::Approx(0.5 * (3 * 2.25 + 5 * 1.5 - 2 * 2.75 + 7) - 1).epsilon(1e-12));
  REQUIRE(ffseg_sample(eb.e, w, FFSEG_SAMPLE_NEAREST, &val) == FFSEG_OK);
  CHECK(val == doctest::Approx(0.5 * (3 * 2 + 5 * 2 - 2 * 3 + 7) - 1));
  // Hand-computed: world (10.75, -7, 5) -> index (1.5, 2, 1): 0.5 * (4.5 + 10 - 2 + 7) - 1 = 8.75.
  const double hand[3] = {10.75, -7, 5};
  REQUIRE(ffseg_sample(eb.e, hand, FFSEG_SAMPLE_LINEAR, &val) == FFSEG_OK);
  CHECK(val == doctest::Approx(8.75));
  // Beyond the grid reads 0; half a voxel out blends with 0.
  world(-3, 1, 1, w);
  REQUIRE(ffseg_sample(eb.e, w, FFSEG_SAMPLE_LINEAR, &val) == FFSEG_OK);
  CHECK(val == 0);
  world(-0.5, 0, 0, w);
  REQUIRE(ffseg_sample(eb.e, w, FFSEG_SAMPLE_LINEAR, &val) == FFSEG_OK);
  CHECK(val == doctest::Approx(0.5 * (0.5 * 7 - 1)));  // half voxel 0, half the zero outside
  CHECK(ffseg_sample(eb.e, w, 7, &val) == FFSEG_ERR_INVALID_ARGUMENT);
  const double nanp[3] = {NAN, 0, 0};
  CHECK(ffseg_sample(eb.e, nanp, 0, &val) == FFSEG_ERR_INVALID_ARGUMENT);
}

TEST_CASE("init_sphere and extract_mesh errors; counts and short buffers") {
  std::vector<uint8_t> buf(20 * 20 * 20, 0);
  const int64_t dims[3] = {20, 20, 20};
  const double A[16] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1};
  EngineBox eb(2, 6);
  const double c[3] = {20, 20, 20};
  CHECK(ffseg_init_sphere(eb.e, 0, c, 5) == FFSEG_ERR_MISUSE);  // no volume yet
  ffseg_volume v = make_volume(buf.data(), FFSEG_U8, dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  CHECK(ffseg_init_sphere(eb.e, 2, c, 5) == FFSEG_ERR_OBJECT_OUT_OF_RANGE);
  CHECK(ffseg_init_sphere(eb.e, 0, c, 0) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(ffseg_init_sphere(eb.e, 0, c, -1) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(ffseg_init_sphere(eb.e, 0, c, NAN) == FFSEG_ERR_INVALID_ARGUMENT);
  const double far[3] = {200, 20, 20};
  CHECK(ffseg_init_sphere(eb.e, 0, far, 5) == FFSEG_ERR_SPHERE_OUTSIDE);
  // Grid box spans -1 .. 39 mm: a ball reaching 1 mm into it is accepted.
  const double edge[3] = {45, 20, 20};
  CHECK(ffseg_init_sphere(eb.e, 0, edge, 5.5) == FFSEG_ERR_SPHERE_OUTSIDE);
  CHECK(ffseg_init_sphere(eb.e, 0, edge, 6.5) == FFSEG_OK);
  // A huge ball containing the whole volume meets it (object 0 again: placed
  // as object 1 it would enclose object 0, which one engine's objects may not).
  CHECK(ffseg_init_sphere(eb.e, 0, c, 500) == FFSEG_OK);
  CHECK(ffseg_init_sphere(eb.e, 0, nullptr, 5) == FFSEG_ERR_NULL_POINTER);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, 5) == FFSEG_OK);

  size_t nv = 0, nt = 0;
  REQUIRE(ffseg_extract_mesh(eb.e, 0, nullptr, 0, nullptr, 0, &nv, &nt) == FFSEG_OK);
  CHECK(nv == 6 * 36);
  CHECK(nt == 12 * 36 - 4);
  std::vector<float> xyz(3 * nv);
  std::vector<uint32_t> tris(3 * nt);
  size_t a = 0, b = 0;
  CHECK(ffseg_extract_mesh(eb.e, 0, xyz.data(), nv - 1, tris.data(), nt, &a, &b) == FFSEG_ERR_BUFFER_TOO_SMALL);
  CHECK(a == nv);
  CHECK(b == nt);
  CHECK(ffseg_extract_mesh(eb.e, 0, xyz.data(), nv, tris.data(), nt - 1, &a, &b) == FFSEG_ERR_BUFFER_TOO_SMALL);
  CHECK(ffseg_extract_mesh(eb.e, 0, xyz.data(), nv, tris.data(), nt, &a, &b) == FFSEG_OK);
  CHECK(ffseg_extract_mesh(eb.e, 5, xyz.data(), nv, tris.data(), nt, &a, &b) == FFSEG_ERR_OBJECT_OUT_OF_RANGE);
  // Object 1 was placed (radius 500) then never replaced; a fresh engine's object is not placed.
  EngineBox eb2(2, 6);
  REQUIRE(ffseg_set_volume(eb2.e, &v) == FFSEG_OK);
  CHECK(ffseg_extract_mesh(eb2.e, 1, nullptr, 0, nullptr, 0, &a, &b) == FFSEG_ERR_MISUSE);
  std::vector<uint8_t> mask(buf.size());
  CHECK(ffseg_rasterize(eb2.e, 1, mask.data(), nullptr) == FFSEG_ERR_MISUSE);
  CHECK(ffseg_rasterize(eb.e, 0, nullptr, nullptr) == FFSEG_ERR_NULL_POINTER);
}

TEST_CASE("set_volume: a single slice along any axis is refused, naming the axis") {
  std::vector<uint8_t> vox(16 * 16 * 16, 1);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  ffseg_test::EngineBox eb(1, 8);
  REQUIRE(eb.e != nullptr);
  for (int axis = 0; axis < 3; ++axis) {
    CAPTURE(axis);
    int64_t dims[3] = {16, 16, 16};
    dims[axis] = 1;
    ffseg_volume v = ffseg_test::make_volume(vox.data(), FFSEG_U8, dims, A);
    CHECK(ffseg_set_volume(eb.e, &v) == FFSEG_ERR_INVALID_VOLUME);
    const std::string msg = ffseg_last_error(eb.e);
    CAPTURE(msg);
    CHECK(msg.find("dims[" + std::to_string(axis) + "] = 1, a single slice") != std::string::npos);
  }
  // Two slices are a (thin) volume.
  const int64_t two[3] = {16, 16, 2};
  ffseg_volume v = ffseg_test::make_volume(vox.data(), FFSEG_U8, two, A);
  CHECK(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
}
