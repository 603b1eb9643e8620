// ffseg_region_mask (thesis 6.2, fig. 6.4): an object's bounding region read
// back through the C API, against the engine's own ownership test, and every
// refusal with its message.
#include <doctest/doctest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "../../capi/capi_internal.h"  // engine_of()
#include "engine.h"
#include "ffseg.h"
#include "test_util.h"

namespace {

const double kIdentity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// A bar of non-zero voxels 40 x 12 x 12 in a 56 x 24 x 20 grid (1 mm).
struct Bar {
  int64_t dims[3] = {56, 24, 20};
  std::vector<uint8_t> v;
  Bar() : v(size_t(56 * 24 * 20), 0) {
    for (int64_t k = 4; k < 16; ++k)
      for (int64_t j = 6; j < 18; ++j)
        for (int64_t i = 8; i < 48; ++i) v[size_t((k * 24 + j) * 56 + i)] = 1;
  }
  size_t voxels() const { return v.size(); }
};

bool has(const char* msg, const char* part) { return msg != nullptr && std::strstr(msg, part) != nullptr; }

std::vector<uint8_t> region_of(ffseg_engine* e, uint32_t object, size_t n) {
  std::vector<uint8_t> m(n, 7);
  REQUIRE(ffseg_region_mask(e, object, m.data(), nullptr) == FFSEG_OK);
  return m;
}

}  // namespace

TEST_CASE("region_mask: two objects in a bar get disjoint regions, each holding its own mesh's voxels") {
  const Bar bar;
  ffseg_test::EngineBox eb(3, 8, int64_t(1) << 16);
  REQUIRE(eb.e != nullptr);
  ffseg_volume vol = ffseg_test::make_volume(bar.v.data(), FFSEG_U8, bar.dims, kIdentity);
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  const double ca[3] = {16, 11.5, 9.5}, cb[3] = {39, 11.5, 9.5};
  REQUIRE(ffseg_init_sphere(eb.e, 0, ca, 3) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 2, cb, 3) == FFSEG_OK);
  std::vector<uint8_t> untouched(bar.voxels(), 7);
  // Before the first step with two objects placed there is no region.
  CHECK(ffseg_region_mask(eb.e, 0, untouched.data(), nullptr) == FFSEG_ERR_MISUSE);
  CHECK(has(ffseg_last_error(eb.e), "no bounding region yet"));
  CHECK(has(ffseg_last_error(nullptr), "region_mask"));
  for (int s = 0; s < 12; ++s) REQUIRE(ffseg_step(eb.e, nullptr) >= 0);

  const std::vector<uint8_t> ra = region_of(eb.e, 0, bar.voxels()), rb = region_of(eb.e, 2, bar.voxels());
  std::vector<uint8_t> ma(bar.voxels()), mb(bar.voxels());
  REQUIRE(ffseg_rasterize(eb.e, 0, ma.data(), nullptr) == FFSEG_OK);
  REQUIRE(ffseg_rasterize(eb.e, 2, mb.data(), nullptr) == FFSEG_OK);
  const ffseg::RegionSet set = ffseg::capi::engine_of(eb.e)->regions();
  size_t na = 0, nb = 0, shared = 0, a_mesh_outside = 0, b_mesh_outside = 0, mesh_a = 0, wrong = 0,
         off_bar_not_seed = 0, unwritten = 0;
  for (int64_t k = 0; k < bar.dims[2]; ++k)
    for (int64_t j = 0; j < bar.dims[1]; ++j)
      for (int64_t i = 0; i < bar.dims[0]; ++i) {
        const size_t x = size_t((k * bar.dims[1] + j) * bar.dims[0] + i);
        unwritten += ra[x] > 1 || rb[x] > 1;  // every voxel written, 0 or 1
        na += ra[x];
        nb += rb[x];
        shared += ra[x] & rb[x];
        mesh_a += ma[x];
        a_mesh_outside += ma[x] && !ra[x];
        b_mesh_outside += mb[x] && !rb[x];
        const uint32_t o = set.owner(i, j, k);
        wrong += ra[x] != (o == 0) || rb[x] != (o == 2);
        // Binary speed is 0 off the bar: only seeds (time 0, the voxels
        // nearest to the mesh's vertices) are owned there.
        if (!bar.v[x] && o != ffseg::RegionSet::kNobody) off_bar_not_seed += set.regions[o].time_at(i, j, k) != 0;
      }
  CHECK(unwritten == 0);
  CHECK(shared == 0);
  CHECK(wrong == 0);
  CHECK(off_bar_not_seed == 0);
  CHECK(mesh_a > 100);
  CHECK(a_mesh_outside == 0);
  CHECK(b_mesh_outside == 0);
  // The two regions split the bar between them, each a good part of it.
  CHECK(na > mesh_a);
  CHECK(na > 12 * 12 * 8);
  CHECK(nb > 12 * 12 * 8);

  // Strides: the same region through a k-fastest layout.
  const int64_t strides[3] = {bar.dims[1] * bar.dims[2], bar.dims[2], 1};
  std::vector<uint8_t> t(bar.voxels(), 7);
  REQUIRE(ffseg_region_mask(eb.e, 2, t.data(), strides) == FFSEG_OK);
  size_t differ = 0;
  for (int64_t k = 0; k < bar.dims[2]; ++k)
    for (int64_t j = 0; j < bar.dims[1]; ++j)
      for (int64_t i = 0; i < bar.dims[0]; ++i)
        differ += t[size_t(i * strides[0] + j * strides[1] + k)] != rb[size_t((k * bar.dims[1] + j) * bar.dims[0] + i)];
  CHECK(differ == 0);

  // Refusals leave the mask untouched and a message.
  CHECK(ffseg_region_mask(eb.e, 0, nullptr, nullptr) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(eb.e), "region_mask: mask is NULL"));
  CHECK(ffseg_region_mask(eb.e, 3, untouched.data(), nullptr) == FFSEG_ERR_OBJECT_OUT_OF_RANGE);
  CHECK(has(ffseg_last_error(eb.e), "object 3"));
  CHECK(ffseg_region_mask(eb.e, 1, untouched.data(), nullptr) == FFSEG_ERR_MISUSE);  // not placed
  CHECK(has(ffseg_last_error(eb.e), "object 1 has no mesh"));
  CHECK(ffseg_region_mask(nullptr, 0, untouched.data(), nullptr) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(nullptr), "region_mask: engine is NULL"));
  // Placing an object again drops its region until the next step.
  REQUIRE(ffseg_init_sphere(eb.e, 0, ca, 3) == FFSEG_OK);
  CHECK(ffseg_region_mask(eb.e, 0, untouched.data(), nullptr) == FFSEG_ERR_MISUSE);
  CHECK(has(ffseg_last_error(eb.e), "object 0 has no bounding region yet"));
  for (uint8_t u : untouched) REQUIRE(u == 7);
  REQUIRE(ffseg_step(eb.e, nullptr) >= 0);
  CHECK(ffseg_region_mask(eb.e, 0, untouched.data(), nullptr) == FFSEG_OK);
}

TEST_CASE("region_mask: a one-object engine and a lone object have no region") {
  const Bar bar;
  ffseg_volume vol = ffseg_test::make_volume(bar.v.data(), FFSEG_U8, bar.dims, kIdentity);
  const double c[3] = {16, 11.5, 9.5};
  std::vector<uint8_t> m(bar.voxels(), 7);
  {
    ffseg_test::EngineBox eb(1, 6, int64_t(1) << 16);
    REQUIRE(eb.e != nullptr);
    CHECK(ffseg_region_mask(eb.e, 0, m.data(), nullptr) == FFSEG_ERR_MISUSE);  // not placed, no volume
    CHECK(std::string(ffseg_last_error(eb.e)).size() > 0);
    REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
    REQUIRE(ffseg_init_sphere(eb.e, 0, c, 3) == FFSEG_OK);
    REQUIRE(ffseg_step(eb.e, nullptr) >= 0);
    CHECK(ffseg_region_mask(eb.e, 0, m.data(), nullptr) == FFSEG_ERR_MISUSE);
    CHECK(has(ffseg_last_error(eb.e), "one-object engine"));
    CHECK(has(ffseg_last_error(nullptr), "one-object engine"));
  }
  {
    ffseg_test::EngineBox eb(2, 6, int64_t(1) << 16);
    REQUIRE(eb.e != nullptr);
    REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
    REQUIRE(ffseg_init_sphere(eb.e, 1, c, 3) == FFSEG_OK);
    REQUIRE(ffseg_step(eb.e, nullptr) >= 0);  // one object placed: no regions stage
    CHECK(ffseg_region_mask(eb.e, 1, m.data(), nullptr) == FFSEG_ERR_MISUSE);
    CHECK(has(ffseg_last_error(eb.e), "no bounding region yet"));
  }
  for (uint8_t u : m) REQUIRE(u == 7);
}
