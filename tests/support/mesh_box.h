// A built cube-sphere mesh of resolution n in its own arena, for the tests
// that call the mesh below the C API.
#pragma once
#include <cstdint>

#include <doctest/doctest.h>

#include "cubesphere.h"
#include "test_util.h"

namespace ffseg_test {

struct MeshBox {
  ffseg::CubeSphere m;
  ArenaBox box;
  explicit MeshBox(uint32_t n) : box([&](ffseg::Arena& a) { m.carve(a, n); }) {
    REQUIRE(box.ok());
    m.build();
  }
};

}  // namespace ffseg_test
