// A bare cube-sphere carved into owned memory, for the stage tests that work
// on hand-made positions, targets and displacements (no engine, no volume);
// TriangleBox adds the self-intersection scratch, for the tests of the guard
// and of the intersection test itself.
#pragma once
#include <cstdint>
#include <vector>

#include <doctest/doctest.h>

#include "cubesphere.h"
#include "mesh_intersection.h"
#include "test_util.h"

namespace ffseg_test {

struct SphereBox {
  ffseg::CubeSphere m;
  ArenaBox box;
  explicit SphereBox(uint32_t n) : box([&](ffseg::Arena& a) { m.carve(a, n); }) {
    REQUIRE(box.ok());
    m.build();
  }
  // Positions of the sphere of radius r around the origin, 3 per vertex.
  std::vector<double> sphere(double r) const {
    std::vector<double> x(size_t(3) * m.nv);
    for (size_t q = 0; q < x.size(); ++q) x[q] = r * m.unit[q];
    return x;
  }
  // Vertex at position p of loop l.
  uint32_t at(uint32_t l, uint32_t p) const { return m.loops[size_t(l) * m.loop_len + p % m.loop_len]; }
};

struct TriangleBox {
  ffseg::CubeSphere m;
  ffseg::TriangleScratch tri;
  ArenaBox box;
  explicit TriangleBox(uint32_t n)
      : box([&](ffseg::Arena& a) {
          m.carve(a, n);
          tri.carve(a, m);
        }) {
    REQUIRE(box.ok());
    m.build();
  }
  std::vector<double> sphere(double r) const {
    std::vector<double> x(size_t(3) * m.nv);
    for (size_t q = 0; q < x.size(); ++q) x[q] = r * m.unit[q];
    return x;
  }
};

}  // namespace ffseg_test
