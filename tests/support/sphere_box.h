// A bare cube-sphere carved into owned memory, for the stage tests that work
// on hand-made positions, targets and displacements (no engine, no volume);
// TriangleBox adds the self-intersection scratch, for the tests of the guard
// and of the intersection test itself; ContactBox also room for obstacles
// (other objects), for the contact test and the guard against them.
#pragma once
#include <cstdint>
#include <initializer_list>
#include <vector>

#include <doctest/doctest.h>

#include "cubesphere.h"
#include "mesh_contact.h"
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

struct ContactBox {
  ffseg::CubeSphere m;
  ffseg::TriangleScratch tri;
  ffseg::ContactScratch cs;
  ArenaBox box;
  ContactBox(uint32_t n, uint32_t max_obstacles)
      : box([&](ffseg::Arena& a) {
          m.carve(a, n);
          tri.carve(a, m);
          cs.carve(a, m, max_obstacles);
        }) {
    REQUIRE(box.ok());
    m.build();
  }
  // Positions of the sphere of radius r around (cx, cy, cz), 3 per vertex.
  std::vector<double> sphere(double r, double cx = 0, double cy = 0, double cz = 0) const {
    std::vector<double> x(size_t(3) * m.nv);
    const double c[3] = {cx, cy, cz};
    for (size_t q = 0; q < x.size(); ++q) x[q] = c[q % 3] + r * m.unit[q];
    return x;
  }
  // The obstacles: the meshes at xs (kept by the caller until the last query).
  void obstacles(std::initializer_list<const std::vector<double>*> xs) {
    std::vector<const double*> p;
    for (const auto* x : xs) p.push_back(x->data());
    ffseg::build_obstacles(m, p.data(), uint32_t(p.size()), cs);
  }
  // mark_contacts() of the mesh at x, into mark (cleared first) when given.
  uint32_t contacts(const std::vector<double>& x, std::vector<uint8_t>* mark) {
    if (mark) mark->assign(m.nv, 0);
    return ffseg::mark_contacts(m, x.data(), cs, mark ? mark->data() : nullptr);
  }
};

}  // namespace ffseg_test
