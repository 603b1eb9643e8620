// The public structs' layouts: no implicit padding anywhere (so appending a
// field always grows sizeof, and struct_size can tell the layouts apart), and
// the reserved fields that fill it are zeroed by init_default and refused when
// not zero.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <vector>
#include <string>

#include "../abi/ffseg_fields.h"
#include "ffseg.h"
#include "test_util.h"

namespace {

struct Walk {
  size_t next = 0;    // where the previous field ended
  int fields = 0;
  std::string gaps;   // "struct.field" for every field that does not start where the previous ended
};

}  // namespace

#define FFSEG_WALK_FIELD(S, F)                                                   \
  if (offsetof(S, F) != w.next) w.gaps += std::string(#S "." #F " ");            \
  w.next = offsetof(S, F) + sizeof(static_cast<S*>(nullptr)->F);                 \
  ++w.fields;
#define FFSEG_WALK_STRUCT(S, FIELDS)                                             \
  SUBCASE(#S) {                                                                  \
    Walk w;                                                                      \
    FIELDS(FFSEG_WALK_FIELD)                                                     \
    CHECK_MESSAGE(w.gaps.empty(), "padding before ", w.gaps);                    \
    CHECK_MESSAGE(w.next == sizeof(S), #S ": fields end at ", w.next, ", sizeof is ", sizeof(S), \
                  " (tail padding, or a field missing from abi/ffseg_fields.h)"); \
    CHECK(w.fields >= 5);                                                        \
  }

TEST_CASE("abi: public structs have no implicit padding, every field listed in abi/ffseg_fields.h") {
  FFSEG_PUBLIC_STRUCTS(FFSEG_WALK_STRUCT)
}

TEST_CASE("abi: reserved fields are zeroed by init_default and must stay 0") {
  ffseg_params p;
  std::memset(&p, 0xAB, sizeof p);
  ffseg_params_init_default(&p);
  CHECK(p.reserved1 == 0u);
  ffseg_config c;
  std::memset(&c, 0xAB, sizeof c);
  ffseg_config_init_default(&c);
  CHECK(c.reserved0 == 0u);

  ffseg_test::EngineBox eb(1, 8);
  REQUIRE(eb.e != nullptr);
  CHECK(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_params q = p;
  q.reserved1 = 1;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::string(ffseg_last_error(eb.e)).find("reserved1") != std::string::npos);
  // A caller whose layout ends before reserved1 is not refused for it.
  q.struct_size = uint32_t(offsetof(ffseg_params, reserved1));
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_OK);
  // grey_respacing (0.7.0) sits where reserved2 had to be 0: 0 is its
  // default (since 0.8.0 automatic, 2 is 0.7.0's off), so a 0.3-0.6 caller
  // gets the default; beyond 2 it is refused.
  CHECK(p.grey_respacing == 0u);
  q = p;
  q.grey_respacing = 2;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_OK);
  q.grey_respacing = 3;
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::string(ffseg_last_error(eb.e)).find("grey_respacing") != std::string::npos);
  // A 0.2 caller (ending after reserved1) is not refused for it.
  q.struct_size = uint32_t(offsetof(ffseg_params, region_width_mm));
  CHECK(ffseg_set_params(eb.e, &q) == FFSEG_OK);
}

TEST_CASE("abi: out-parameters on failure are what ffseg.h says") {
  // workspace_size: *bytes = 0; create: *out = NULL.
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.max_objects = 0;
  size_t bytes = 12345;
  CHECK(ffseg_workspace_size(&c, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(bytes == 0u);
  ffseg_engine* out = reinterpret_cast<ffseg_engine*>(uintptr_t(64));
  alignas(64) static unsigned char small[64];
  ffseg_config_init_default(&c);
  CHECK(ffseg_create(&c, small, sizeof small, &out) == FFSEG_ERR_WORKSPACE_TOO_SMALL);
  CHECK(out == nullptr);

  ffseg_test::EngineBox eb(1, 8);
  REQUIRE(eb.e != nullptr);
  // No volume yet: sample, step, extract_mesh, rasterize fail and write nothing.
  const double p[3] = {4, 4, 4};
  double value = -7.5;
  CHECK(ffseg_sample(eb.e, p, FFSEG_SAMPLE_NEAREST, &value) == FFSEG_ERR_MISUSE);
  CHECK(value == -7.5);
  ffseg_step_info info, before;
  std::memset(&info, 0xAB, sizeof info);
  info.struct_size = sizeof info;
  before = info;
  CHECK(ffseg_step(eb.e, &info) == FFSEG_ERR_MISUSE);
  CHECK(std::memcmp(&info, &before, sizeof info) == 0);
  size_t nv = 99, nt = 98;
  CHECK(ffseg_extract_mesh(eb.e, 0, nullptr, 0, nullptr, 0, &nv, &nt) == FFSEG_ERR_MISUSE);
  CHECK((nv == 99u && nt == 98u));
  CHECK(ffseg_extract_mesh(eb.e, 5, nullptr, 0, nullptr, 0, &nv, &nt) == FFSEG_ERR_OBJECT_OUT_OF_RANGE);
  CHECK((nv == 99u && nt == 98u));

  const int64_t dims[3] = {16, 16, 16};
  std::vector<uint8_t> ones(16 * 16 * 16, 1), twos(16 * 16 * 16, 2);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const ffseg_volume v1 = ffseg_test::make_volume(ones.data(), FFSEG_U8, dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &v1) == FFSEG_OK);
  std::vector<uint8_t> mask(ones.size(), 7);
  CHECK(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_ERR_MISUSE);  // object not placed
  CHECK(std::count(mask.begin(), mask.end(), uint8_t(7)) == long(mask.size()));

  // A refused set_volume keeps the previous volume (its voxels still read).
  ffseg_volume v2 = ffseg_test::make_volume(twos.data(), FFSEG_U8, dims, A);
  v2.data_bytes -= 1;
  CHECK(ffseg_set_volume(eb.e, &v2) == FFSEG_ERR_INVALID_VOLUME);
  CHECK(ffseg_sample(eb.e, p, FFSEG_SAMPLE_NEAREST, &value) == FFSEG_OK);
  CHECK(value == 1.0);

  // A refused init_sphere keeps the mesh the object had.
  const double centre[3] = {8, 8, 8}, far_away[3] = {500, 8, 8};
  REQUIRE(ffseg_init_sphere(eb.e, 0, centre, 3.0) == FFSEG_OK);
  std::vector<float> xyz0, xyz1;
  std::vector<uint32_t> tris0, tris1;
  REQUIRE(ffseg_test::extract(eb.e, 0, &xyz0, &tris0));
  CHECK(ffseg_init_sphere(eb.e, 0, far_away, 3.0) == FFSEG_ERR_SPHERE_OUTSIDE);
  REQUIRE(ffseg_test::extract(eb.e, 0, &xyz1, &tris1));
  CHECK(xyz0 == xyz1);

  // BUFFER_TOO_SMALL: the counts are written, the buffers are not.
  std::vector<float> few(3 * 4, -1.0f);
  std::vector<uint32_t> tris(tris0.size());
  nv = nt = 0;
  CHECK(ffseg_extract_mesh(eb.e, 0, few.data(), 4, tris.data(), tris.size() / 3, &nv, &nt) ==
        FFSEG_ERR_BUFFER_TOO_SMALL);
  CHECK(nv == xyz0.size() / 3);
  CHECK(nt == tris0.size() / 3);
  CHECK(std::count(few.begin(), few.end(), -1.0f) == long(few.size()));
  CHECK(std::count(tris.begin(), tris.end(), 0u) == long(tris.size()));
}
