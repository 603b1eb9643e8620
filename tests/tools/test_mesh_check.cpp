// Tests for tests/support/mesh_check.*: hand-made meshes with known defects.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "support/mesh_check.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Mesh {
  std::vector<float> xyz;
  std::vector<uint32_t> tri;
  std::size_t nv() const { return xyz.size() / 3; }
  std::size_t nt() const { return tri.size() / 3; }
  uint32_t add_vertex(double x, double y, double z) {
    xyz.push_back(float(x));
    xyz.push_back(float(y));
    xyz.push_back(float(z));
    return uint32_t(nv() - 1);
  }
  void add_tri(uint32_t a, uint32_t b, uint32_t c) {
    tri.push_back(a);
    tri.push_back(b);
    tri.push_back(c);
  }
  void append(const Mesh& m) {
    const uint32_t off = uint32_t(nv());
    xyz.insert(xyz.end(), m.xyz.begin(), m.xyz.end());
    for (uint32_t i : m.tri) tri.push_back(i + off);
  }
};

std::size_t intersections(const Mesh& m) {
  return ffseg_test::count_self_intersections(m.xyz.data(), m.nv(), m.tri.data(), m.nt());
}
ffseg_test::SelfIntersectionReport report(const Mesh& m) {
  return ffseg_test::check_self_intersections(m.xyz.data(), m.nv(), m.tri.data(), m.nt());
}
bool closed(const Mesh& m) {
  return ffseg_test::is_closed_oriented_manifold(m.xyz.data(), m.nv(), m.tri.data(), m.nt());
}
std::size_t flips(const Mesh& m, double c = -0.5, std::size_t* deg = nullptr) {
  return ffseg_test::count_normal_flips(m.xyz.data(), m.nv(), m.tri.data(), m.nt(), c, deg);
}
double volume(const Mesh& m) { return ffseg_test::enclosed_volume(m.xyz.data(), m.nv(), m.tri.data(), m.nt()); }
double area(const Mesh& m) { return ffseg_test::surface_area(m.xyz.data(), m.nv(), m.tri.data(), m.nt()); }

// Regular octahedron |x|+|y|+|z| = r, outward winding.
Mesh octahedron(double r = 1.0) {
  Mesh m;
  const uint32_t px = m.add_vertex(r, 0, 0), nx = m.add_vertex(-r, 0, 0);
  const uint32_t py = m.add_vertex(0, r, 0), ny = m.add_vertex(0, -r, 0);
  const uint32_t pz = m.add_vertex(0, 0, r), nz = m.add_vertex(0, 0, -r);
  for (int sx = 0; sx < 2; ++sx)
    for (int sy = 0; sy < 2; ++sy)
      for (int sz = 0; sz < 2; ++sz) {
        uint32_t a = sx ? nx : px, b = sy ? ny : py, c = sz ? nz : pz;
        if ((sx + sy + sz) % 2) m.add_tri(a, c, b);
        else m.add_tri(a, b, c);
      }
  return m;
}

// Octahedron subdivided `levels` times (8 * 4^levels triangles), projected on
// the sphere of radius r.
Mesh sphere(int levels, double r = 1.0) {
  Mesh m = octahedron(1.0);
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      double x = 0.5 * (double(m.xyz[3 * a]) + m.xyz[3 * b]);
      double y = 0.5 * (double(m.xyz[3 * a + 1]) + m.xyz[3 * b + 1]);
      double z = 0.5 * (double(m.xyz[3 * a + 2]) + m.xyz[3 * b + 2]);
      uint32_t v = m.add_vertex(x, y, z);
      mid.emplace(key, v);
      return v;
    };
    std::vector<uint32_t> old;
    old.swap(m.tri);
    for (std::size_t t = 0; t < old.size(); t += 3) {
      uint32_t a = old[t], b = old[t + 1], c = old[t + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      m.add_tri(a, ab, ca);
      m.add_tri(b, bc, ab);
      m.add_tri(c, ca, bc);
      m.add_tri(ab, bc, ca);
    }
  }
  for (std::size_t v = 0; v < m.nv(); ++v) {
    double x = m.xyz[3 * v], y = m.xyz[3 * v + 1], z = m.xyz[3 * v + 2];
    double s = r / std::sqrt(x * x + y * y + z * z);
    m.xyz[3 * v] = float(x * s);
    m.xyz[3 * v + 1] = float(y * s);
    m.xyz[3 * v + 2] = float(z * s);
  }
  return m;
}

Mesh tetrahedron(double ox, double oy, double oz, double s = 1.0) {
  Mesh m;
  uint32_t a = m.add_vertex(ox, oy, oz), b = m.add_vertex(ox + s, oy, oz);
  uint32_t c = m.add_vertex(ox, oy + s, oz), d = m.add_vertex(ox, oy, oz + s);
  m.add_tri(a, c, b);  // z = oz face, normal -z
  m.add_tri(a, b, d);  // y = oy face, normal -y
  m.add_tri(a, d, c);  // x = ox face, normal -x
  m.add_tri(b, c, d);  // slanted face, normal +(1,1,1)
  return m;
}

}  // namespace

TEST_CASE("mesh check: closed octahedron") {
  const Mesh m = octahedron(1.0);
  CHECK(intersections(m) == 0);
  CHECK(report(m).shared_vertex_pairs == 0);
  CHECK(closed(m));
  std::size_t deg = 99;
  CHECK(flips(m, -0.5, &deg) == 0);
  CHECK(deg == 0);
  // |x|+|y|+|z| <= 1: volume 4/3, area 8 * (sqrt(3)/2) * (sqrt 2)^2 / 2 = 4 sqrt 3
  CHECK(volume(m) == doctest::Approx(4.0 / 3.0).epsilon(1e-12));
  CHECK(area(m) == doctest::Approx(4.0 * std::sqrt(3.0)).epsilon(1e-12));
  // scaled by 2.5: volume scales with the cube
  const Mesh m2 = octahedron(2.5);
  CHECK(volume(m2) == doctest::Approx(4.0 / 3.0 * 2.5 * 2.5 * 2.5).epsilon(1e-12));
}

TEST_CASE("mesh check: sphere is clean and its volume converges") {
  const Mesh m = sphere(4, 10.0);  // 2048 triangles
  CHECK(m.nt() == 2048);
  const auto rep = report(m);
  CHECK(rep.disjoint_pairs == 0);
  CHECK(rep.shared_vertex_pairs == 0);
  CHECK(rep.degenerate_triangles == 0);
  CHECK(closed(m));
  CHECK(flips(m, 0.5) == 0);  // neighbouring faces of a fine sphere are nearly parallel
  const double exact = 4.0 / 3.0 * kPi * 1000.0;
  CHECK(volume(m) < exact);
  CHECK(volume(m) > 0.98 * exact);
  CHECK(area(m) < 4.0 * kPi * 100.0);
  CHECK(area(m) > 0.98 * 4.0 * kPi * 100.0);
  // reversed winding: volume negates, still closed
  Mesh r = m;
  for (std::size_t t = 0; t < r.nt(); ++t) std::swap(r.tri[3 * t + 1], r.tri[3 * t + 2]);
  CHECK(volume(r) == doctest::Approx(-volume(m)).epsilon(1e-12));
  CHECK(closed(r));
}

TEST_CASE("mesh check: two interpenetrating tetrahedra") {
  Mesh m = tetrahedron(0, 0, 0);
  CHECK(closed(m));
  CHECK(volume(m) == doctest::Approx(1.0 / 6.0).epsilon(1e-12));
  Mesh apart = m;
  apart.append(tetrahedron(3, 0, 0));
  CHECK(intersections(apart) == 0);
  CHECK(closed(apart));

  m.append(tetrahedron(0.25, 0.25, 0.25));
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  const std::size_t n = ffseg_test::count_self_intersections(m.xyz.data(), m.nv(), m.tri.data(), m.nt(), &pairs, 100);
  CHECK(n > 0);
  CHECK(pairs.size() == n);
  for (auto& p : pairs) {  // every offending pair has one face from each tetrahedron
    CHECK(p.first < 4);
    CHECK(p.second >= 4);
  }
  CHECK(closed(m));  // edge-manifold, yet self-intersecting
}

TEST_CASE("mesh check: vertex pushed through the opposite side") {
  Mesh m = sphere(2, 1.0);  // 128 triangles
  REQUIRE(intersections(m) == 0);
  // vertex 4 is the +z pole of the base octahedron; push it to z = -1.5
  REQUIRE(m.xyz[3 * 4 + 2] == doctest::Approx(1.0));
  m.xyz[3 * 4 + 2] = -1.5f;
  const auto rep = report(m);
  CHECK(rep.disjoint_pairs > 0);
  CHECK(closed(m));  // topology unchanged
  REQUIRE(!rep.first_pairs.empty());
  // each offending pair involves a triangle of the pole's fan
  for (auto& p : rep.first_pairs) {
    bool fan = false;
    for (uint32_t t : {p.first, p.second})
      for (int k = 0; k < 3; ++k) fan = fan || m.tri[3 * t + k] == 4;
    CHECK(fan);
  }
}

TEST_CASE("mesh check: flipped triangle") {
  Mesh m = sphere(3, 5.0);  // 512 triangles
  REQUIRE(closed(m));
  REQUIRE(flips(m) == 0);
  const double v0 = volume(m);
  std::swap(m.tri[3 * 100 + 1], m.tri[3 * 100 + 2]);
  CHECK_FALSE(closed(m));
  CHECK(flips(m) == 3);  // its three edges
  CHECK(intersections(m) == 0);
  CHECK(volume(m) < v0);
}

TEST_CASE("mesh check: mesh with a hole is not closed") {
  Mesh m = sphere(2, 1.0);
  m.tri.erase(m.tri.begin() + 3 * 7, m.tri.begin() + 3 * 8);
  CHECK_FALSE(closed(m));
  CHECK(intersections(m) == 0);
  CHECK(flips(m) == 0);
  // a duplicated face is not closed either
  Mesh d = octahedron();
  d.add_tri(d.tri[0], d.tri[1], d.tri[2]);
  CHECK_FALSE(closed(d));
  // nor are empty meshes, repeated indices or indices out of range
  CHECK_FALSE(ffseg_test::is_closed_oriented_manifold(nullptr, 0, nullptr, 0));
  Mesh bad = octahedron();
  bad.tri[0] = 100;
  CHECK_FALSE(closed(bad));
}

TEST_CASE("mesh check: coplanar triangles") {
  // overlapping, no shared vertex
  Mesh m;
  m.add_tri(m.add_vertex(0, 0, 0), m.add_vertex(2, 0, 0), m.add_vertex(0, 2, 0));
  m.add_tri(m.add_vertex(0.5, 0.5, 0), m.add_vertex(3, 0.5, 0), m.add_vertex(0.5, 3, 0));
  CHECK(intersections(m) == 1);
  // one inside the other (no edge crossings)
  Mesh in;
  in.add_tri(in.add_vertex(0, 0, 0), in.add_vertex(4, 0, 0), in.add_vertex(0, 4, 0));
  in.add_tri(in.add_vertex(0.5, 0.5, 0), in.add_vertex(1, 0.5, 0), in.add_vertex(0.5, 1, 0));
  CHECK(intersections(in) == 1);
  // apart in the same plane
  Mesh ap;
  ap.add_tri(ap.add_vertex(0, 0, 0), ap.add_vertex(1, 0, 0), ap.add_vertex(0, 1, 0));
  ap.add_tri(ap.add_vertex(1, 1, 0), ap.add_vertex(2, 1, 0), ap.add_vertex(1, 2, 0));
  CHECK(intersections(ap) == 0);
  // parallel planes, overlapping in projection
  Mesh par;
  par.add_tri(par.add_vertex(0, 0, 0), par.add_vertex(2, 0, 0), par.add_vertex(0, 2, 0));
  par.add_tri(par.add_vertex(0.5, 0.5, 0.01), par.add_vertex(3, 0.5, 0.01), par.add_vertex(0.5, 3, 0.01));
  CHECK(intersections(par) == 0);

  // sharing one vertex and folded over each other (shared-vertex counter)
  Mesh fold;
  const uint32_t o = fold.add_vertex(0, 0, 0);
  fold.add_tri(o, fold.add_vertex(2, 0, 0), fold.add_vertex(0, 2, 0));
  fold.add_tri(o, fold.add_vertex(2, 1, 0), fold.add_vertex(1, 2, 0));
  auto rep = report(fold);
  CHECK(rep.disjoint_pairs == 0);
  CHECK(rep.shared_vertex_pairs == 1);
  // sharing one vertex, side by side in a fan: fine
  Mesh fan;
  const uint32_t c = fan.add_vertex(0, 0, 0);
  fan.add_tri(c, fan.add_vertex(2, 0, 0), fan.add_vertex(2, 1, 0));
  fan.add_tri(c, fan.add_vertex(1, 2, 0), fan.add_vertex(0, 2, 0));
  fan.add_tri(c, fan.add_vertex(-1, -1, 0), fan.add_vertex(1, -2, 0));
  rep = report(fan);
  CHECK(rep.disjoint_pairs == 0);
  CHECK(rep.shared_vertex_pairs == 0);
}

TEST_CASE("mesh check: triangles sharing one vertex in 3D") {
  Mesh base;
  const uint32_t o = base.add_vertex(0, 0, 0);
  base.add_tri(o, base.add_vertex(1, 0, 0), base.add_vertex(0, 1, 0));

  Mesh pierce = base;  // cuts through the first triangle along x = y
  pierce.add_tri(o, pierce.add_vertex(0.2, 0.2, -1), pierce.add_vertex(0.2, 0.2, 1));
  auto rep = report(pierce);
  CHECK(rep.disjoint_pairs == 0);
  CHECK(rep.shared_vertex_pairs == 1);

  Mesh touch = base;  // crosses the plane only at the shared vertex
  touch.add_tri(o, touch.add_vertex(-0.2, -0.2, -1), touch.add_vertex(-0.2, -0.2, 1));
  CHECK(report(touch).shared_vertex_pairs == 0);

  Mesh above = base;  // entirely on one side except the shared vertex
  above.add_tri(o, above.add_vertex(1, 1, 1), above.add_vertex(0, 1, 2));
  CHECK(report(above).shared_vertex_pairs == 0);

  // no shared index: a vertex touching the other face counts (closed sets)
  Mesh tv = base;
  tv.add_tri(tv.add_vertex(0.2, 0.2, 0), tv.add_vertex(0.2, 0.2, 1), tv.add_vertex(0.5, 0.2, 1));
  CHECK(intersections(tv) == 1);
  // ... and one hovering just above does not
  Mesh hv = base;
  hv.add_tri(hv.add_vertex(0.2, 0.2, 1e-3), hv.add_vertex(0.2, 0.2, 1), hv.add_vertex(0.5, 0.2, 1));
  CHECK(intersections(hv) == 0);
  // edge through the interior of the other triangle
  Mesh ed = base;
  ed.add_tri(ed.add_vertex(0.2, 0.2, -1), ed.add_vertex(0.3, 0.2, 1), ed.add_vertex(3, 3, 3));
  CHECK(intersections(ed) == 1);
}

TEST_CASE("mesh check: degenerate triangles are counted, not tested") {
  Mesh m = octahedron();
  const uint32_t a = m.add_vertex(0, 0, 0), b = m.add_vertex(1, 1, 1), c = m.add_vertex(2, 2, 2);
  m.add_tri(a, b, c);  // collinear: zero area, pierces nothing by definition
  std::size_t deg = 0;
  flips(m, -0.5, &deg);
  CHECK(deg == 1);
  CHECK(report(m).degenerate_triangles == 1);
  CHECK(intersections(m) == 0);
}

TEST_CASE("mesh check: 32k-triangle sphere checks in near-linear time") {
  const Mesh m = sphere(6, 50.0);  // 32768 triangles
  REQUIRE(m.nt() == 32768);
  const auto t0 = std::chrono::steady_clock::now();
  const auto rep = report(m);
  const auto t1 = std::chrono::steady_clock::now();
  const bool cl = closed(m);
  const std::size_t fl = flips(m);
  const auto t2 = std::chrono::steady_clock::now();
  CHECK(rep.disjoint_pairs == 0);
  CHECK(rep.shared_vertex_pairs == 0);
  CHECK(cl);
  CHECK(fl == 0);
  // a quadratic scan would test ~5e8 pairs; the grid keeps it to a few dozen per triangle
  CHECK(rep.candidate_pairs < 40 * m.nt());
  MESSAGE("self-intersection check of " << m.nt() << " triangles: "
          << std::chrono::duration<double, std::milli>(t1 - t0).count() << " ms ("
          << rep.candidate_pairs << " pair tests); closed+flips: "
          << std::chrono::duration<double, std::milli>(t2 - t1).count() << " ms");
}

TEST_CASE("mesh check: grid search equals the all-pairs scan on a random triangle soup") {
  // 150 triangles over a pool of 60 points, so many pairs share one vertex
  uint32_t state = 2463534242u;
  auto rnd = [&]() {  // xorshift32, deterministic
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return state;
  };
  for (int trial = 0; trial < 3; ++trial) {
    Mesh m;
    for (int v = 0; v < 60; ++v)
      m.add_vertex((rnd() % 1000) / 100.0, (rnd() % 1000) / 100.0, trial == 2 ? 0.0 : (rnd() % 1000) / 100.0);
    while (m.nt() < 150) {
      uint32_t a = rnd() % 60, b = rnd() % 60, c = rnd() % 60;
      if (a != b && b != c && a != c) m.add_tri(a, b, c);
    }
    const auto rep = report(m);
    std::size_t disjoint = 0, shared = 0, deg = 0;
    for (uint32_t i = 0; i < m.nt(); ++i)
      for (uint32_t j = i + 1; j < m.nt(); ++j) {
        const uint32_t two[6] = {m.tri[3 * i], m.tri[3 * i + 1], m.tri[3 * i + 2],
                                 m.tri[3 * j], m.tri[3 * j + 1], m.tri[3 * j + 2]};
        const auto r = ffseg_test::check_self_intersections(m.xyz.data(), m.nv(), two, 2, 0);
        disjoint += r.disjoint_pairs;
        shared += r.shared_vertex_pairs;
        if (r.degenerate_triangles) ++deg;
      }
    CHECK(rep.disjoint_pairs == disjoint);
    CHECK(rep.shared_vertex_pairs == shared);
    CHECK(rep.disjoint_pairs > 0);  // a dense soup is full of intersections
    CHECK(deg == 0);
  }
}
