// The cube-sphere's combinatorics (src/mesh/cubesphere.h): valence, loops,
// faces, Euler characteristic, orientation, face adjacency.
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

TEST_CASE("cube-sphere combinatorics: valence, loops, faces, Euler, orientation") {
  for (uint32_t n : {2u, 3u, 5u, 8u, 21u}) {
    CAPTURE(n);
    MeshBox box(n);
    const ffseg::CubeSphere& m = box.m;
    REQUIRE(m.nv == 6 * n * n);
    // Every vertex has 4 distinct neighbours, and adjacency is symmetric.
    std::set<std::pair<uint32_t, uint32_t>> edges;
    for (uint32_t v = 0; v < m.nv; ++v) {
      std::set<uint32_t> s(m.nbr + 4 * v, m.nbr + 4 * v + 4);
      CHECK(s.size() == 4);
      CHECK(s.count(v) == 0);
      for (uint32_t w : s) {
        CHECK(std::count(m.nbr + 4 * w, m.nbr + 4 * w + 4, v) == 1);
        edges.insert({std::min(v, w), std::max(v, w)});
      }
    }
    CHECK(edges.size() == size_t(12) * n * n);
    // Loops: 3n loops of 4n distinct vertices, consecutive entries adjacent, every
    // edge on exactly one loop, every vertex on two loops of different groups.
    REQUIRE(m.nloops == 3 * n);
    std::map<std::pair<uint32_t, uint32_t>, int> edge_use;
    std::vector<int> vcount(m.nv, 0);
    for (uint32_t l = 0; l < m.nloops; ++l) {
      const uint32_t* L = m.loops + size_t(l) * m.loop_len;
      std::set<uint32_t> distinct(L, L + m.loop_len);
      CHECK(distinct.size() == 4 * n);
      for (uint32_t p = 0; p < m.loop_len; ++p) {
        const uint32_t a = L[p], b = L[(p + 1) % m.loop_len];
        CHECK(std::count(m.nbr + 4 * a, m.nbr + 4 * a + 4, b) == 1);
        edge_use[{std::min(a, b), std::max(a, b)}]++;
        vcount[a]++;
      }
    }
    CHECK(edge_use.size() == edges.size());
    for (auto& kv : edge_use) CHECK(kv.second == 1);
    for (uint32_t v = 0; v < m.nv; ++v) {
      CHECK(vcount[v] == 2);
      const uint32_t g0 = m.vloop[2 * v] / n, g1 = m.vloop[2 * v + 1] / n;
      CHECK(g0 != g1);
      const uint32_t face_axis = (v / (n * n)) / 2;
      CHECK(g0 != face_axis);
      CHECK(g1 != face_axis);
      CHECK(m.loops[size_t(m.vloop[2 * v]) * m.loop_len + m.vpos[2 * v]] == v);
      CHECK(m.loops[size_t(m.vloop[2 * v + 1]) * m.loop_len + m.vpos[2 * v + 1]] == v);
    }
    // Loops turn counter-clockwise around their axis.
    for (uint32_t l = 0; l < m.nloops; ++l) {
      const uint32_t ax = l / n, a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
      double turn = 0;
      const uint32_t* L = m.loops + size_t(l) * m.loop_len;
      for (uint32_t p = 0; p < m.loop_len; ++p) {
        const double* u = m.unit + 3 * L[p];
        const double* w = m.unit + 3 * L[(p + 1) % m.loop_len];
        turn += u[a1] * w[a2] - u[a2] * w[a1];
      }
      CHECK(turn > 0);
    }
    // Faces: 6n^2 - 6 quads, 8 triangles; consecutive corners are mesh edges.
    size_t quads = 0, tris = 0;
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      const uint32_t* q = m.faces + 4 * f;
      const int k = q[3] == ffseg::kNone ? 3 : 4;
      (k == 4 ? quads : tris)++;
      for (int i = 0; i < k; ++i) {
        const uint32_t a = q[i], b = q[(i + 1) % k];
        CHECK(edges.count({std::min(a, b), std::max(a, b)}) == 1);
      }
    }
    CHECK(quads == size_t(6) * n * n - 6);
    CHECK(tris == 8);
    // Triangulated: closed, consistently oriented (every directed edge once, its
    // reverse present), Euler characteristic 2, outward (positive volume).
    std::vector<uint32_t> T(size_t(3) * m.triangle_count());
    ffseg_test::triangles_of(m, T.data());
    std::set<std::pair<uint32_t, uint32_t>> directed;
    for (size_t t = 0; t < T.size() / 3; ++t)
      for (int i = 0; i < 3; ++i) {
        const bool fresh = directed.insert({T[3 * t + i], T[3 * t + (i + 1) % 3]}).second;
        CHECK(fresh);
      }
    for (auto& de : directed) CHECK(directed.count({de.second, de.first}) == 1);
    const long V = long(m.nv), E = long(directed.size() / 2), F = long(T.size() / 3);
    CHECK(V - E + F == 2);
    CHECK(ffseg_test::signed_volume(m.unit, T) > 0);
  }
}

TEST_CASE("cube-sphere face adjacency: every face edge has the face across it, symmetric") {
  for (uint32_t n : {2u, 5u, 16u}) {
    CAPTURE(n);
    MeshBox box(n);
    const ffseg::CubeSphere& m = box.m;
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      const int k = m.faces[4 * f + 3] == ffseg::kNone ? 3 : 4;
      for (int e = 0; e < k; ++e) {
        const uint32_t g = m.fadj[4 * f + e];
        REQUIRE(g != ffseg::kNone);
        CHECK(g != f);
        CHECK(std::count(m.fadj + 4 * g, m.fadj + 4 * g + 4, f) == 1);
      }
      if (k == 3) CHECK(m.fadj[4 * f + 3] == ffseg::kNone);
    }
    for (uint32_t v = 0; v < m.nv; ++v)
      for (int q = 0; q < 4; ++q) CHECK(m.vfaces[4 * v + q] != ffseg::kNone);
  }
}
