// The public structs' layouts: no implicit padding anywhere (so appending a
// field always grows sizeof, and struct_size can tell the layouts apart), and
// the reserved fields that fill it are zeroed by init_default and refused when
// not zero.
#include <doctest/doctest.h>

#include <cstddef>
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
}
