// Contact between meshes (src/mesh/mesh_contact.h): crossings between two
// objects' triangles and one object inside another, on bare cube-spheres,
// against a brute-force test of every triangle pair.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "cubesphere.h"
#include "mesh_contact.h"
#include "triangle_crossing.h"
#include "triangulation.h"
#include "support/sphere_box.h"
#include "test_util.h"

using ffseg_test::ContactBox;

namespace {

// Every triangle of x against every triangle of each obstacle: the crossing
// pairs, and the vertices of x's triangles among them marked.
uint32_t brute_crossings(const ffseg::CubeSphere& m, const std::vector<double>& x,
                         const std::vector<const std::vector<double>*>& obst, std::vector<uint8_t>& mark) {
  const uint32_t nt = m.triangle_count();
  std::vector<uint32_t> tx(3 * size_t(nt)), ty(3 * size_t(nt));
  ffseg::triangulate(m, x.data(), tx.data());
  mark.assign(m.nv, 0);
  uint32_t count = 0;
  for (const auto* y : obst) {
    ffseg::triangulate(m, y->data(), ty.data());
    for (uint32_t t = 0; t < nt; ++t)
      for (uint32_t u = 0; u < nt; ++u) {
        const double* A[3];
        const double* B[3];
        for (int k = 0; k < 3; ++k) {
          A[k] = x.data() + 3 * size_t(tx[3 * size_t(t) + k]);
          B[k] = y->data() + 3 * size_t(ty[3 * size_t(u) + k]);
        }
        if (!ffseg::detail::disjoint_triangles_cross(A, B)) continue;
        ++count;
        for (int k = 0; k < 3; ++k) mark[tx[3 * size_t(t) + k]] = 1;
      }
  }
  return count;
}

double dist(const double* p, const double* c) {
  return std::sqrt((p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) + (p[2] - c[2]) * (p[2] - c[2]));
}

}  // namespace

TEST_CASE("mesh contact: spheres apart have no contact, with or without marks") {
  ContactBox b(12, 2);
  const auto A = b.sphere(10), B = b.sphere(10, 20.5, 0.3, -0.2), C = b.sphere(5, 0, 80, 0);
  b.obstacles({&B, &C});
  std::vector<uint8_t> mark;
  CHECK(b.contacts(A, &mark) == 0);
  CHECK(b.contacts(A, nullptr) == 0);
  uint32_t marked = 0;
  for (uint8_t v : mark) marked += v;
  CHECK(marked == 0);
  // A small sphere in a corner of A's box, outside A: the boxes nest, the
  // ray test decides.
  const auto D = b.sphere(1, 7.5, 7.5, 7.5);
  b.obstacles({&A});
  CHECK(b.contacts(D, &mark) == 0);
  b.obstacles({&D});
  CHECK(b.contacts(A, &mark) == 0);
}

TEST_CASE("mesh contact: overlapping spheres cross, and only the vertices near the contact are marked") {
  for (uint32_t n : {8u, 12u, 21u}) {
    CAPTURE(n);
    ContactBox b(n, 1);
    const double edge = 10.0 * 1.6 / n;
    const auto A = b.sphere(10);
    for (double d : {19.7, 18.0, 12.0}) {
      CAPTURE(d);
      const double c[3] = {d, 0.37, -0.21};
      const auto B = b.sphere(10, c[0], c[1], c[2]);
      b.obstacles({&B});
      std::vector<uint8_t> mark;
      const uint32_t pairs = b.contacts(A, &mark);
      CHECK(pairs > 0);
      CHECK(b.contacts(A, nullptr) == 1);
      std::vector<uint8_t> ref;
      CHECK(brute_crossings(b.m, A, {&B}, ref) == pairs);
      CHECK(mark == ref);
      uint32_t marked = 0;
      for (uint32_t v = 0; v < b.m.nv; ++v) {
        if (!mark[v]) continue;
        ++marked;
        // A marked vertex belongs to a triangle straddling B's surface.
        CHECK(std::fabs(dist(&A[3 * size_t(v)], c) - 10.0) < 1.5 * edge);
      }
      CHECK(marked > 0);
      CHECK(marked < b.m.nv / 2);
      // The other way round: B's vertices near A's surface.
      b.obstacles({&A});
      CHECK(b.contacts(B, &mark) == pairs);
      const double o[3] = {0, 0, 0};
      for (uint32_t v = 0; v < b.m.nv; ++v)
        if (mark[v]) CHECK(std::fabs(dist(&B[3 * size_t(v)], o) - 10.0) < 1.5 * edge);
    }
  }
}

TEST_CASE("mesh contact: a sphere inside another is found both ways, every vertex of the query marked") {
  ContactBox b(12, 2);
  const auto A = b.sphere(10);
  // Off centre, and concentric with the same topology (rays from a vertex of
  // one towards the other's vertices and edges, by symmetry).
  for (const auto& inner : {b.sphere(4, 1.0, 2.0, -1.5), b.sphere(5), b.sphere(9.9)}) {
    b.obstacles({&A});
    std::vector<uint8_t> mark;
    CHECK(b.contacts(inner, &mark) == 1);
    CHECK(b.contacts(inner, nullptr) == 1);
    for (uint32_t v = 0; v < b.m.nv; ++v) REQUIRE(mark[v] == 1);
    b.obstacles({&inner});
    CHECK(b.contacts(A, &mark) == 1);
    for (uint32_t v = 0; v < b.m.nv; ++v) REQUIRE(mark[v] == 1);
  }
  // Two obstacles, the query inside the second only; with a region around
  // the query (the far one left out, A's faces there only in the grid, the
  // rest of A set up for the ray test when asked), inside and outside.
  const auto far = b.sphere(3, 40, 0, 0), small = b.sphere(2, 1, 1, 1), out = b.sphere(1, 7.5, 7.5, 7.5);
  b.obstacles({&far, &A});
  CHECK(b.contacts(small, nullptr) == 1);
  const double* two[2] = {far.data(), A.data()};
  const double around_small[6] = {-1, -1, -1, 3, 3, 3}, around_out[6] = {6.5, 6.5, 6.5, 8.5, 8.5, 8.5};
  ffseg::build_obstacles(b.m, two, 2, b.cs, around_small);
  CHECK(b.cs.state[0] == 0);
  CHECK(b.cs.state[1] == ffseg::ContactScratch::kActive);
  CHECK(b.contacts(small, nullptr) == 1);
  CHECK(b.cs.state[1] == (ffseg::ContactScratch::kActive | ffseg::ContactScratch::kComplete));
  ffseg::build_obstacles(b.m, two, 2, b.cs, around_out);
  std::vector<uint8_t> mark;
  CHECK(b.contacts(out, &mark) == 0);
}

TEST_CASE("mesh contact: jittered spheres and spikes agree with every triangle pair tested") {
  // Rough spheres at random distances (apart, touching, deep), some with a
  // spike (a vertex pulled far out: wide triangles outside the grid's
  // cells), several obstacles at once: the crossings and the marks equal
  // the brute-force all-pairs count.
  std::mt19937_64 rng(16016);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  uint32_t crossing_cases = 0, clean_cases = 0;
  for (uint32_t n : {6u, 8u, 12u}) {
    ContactBox b(n, 3);
    const uint32_t nv = b.m.nv;
    auto rough = [&](double r, const double* c, double amp) {
      std::vector<double> x(size_t(3) * nv);
      for (uint32_t v = 0; v < nv; ++v) {
        const double rr = r * (1 + amp * U(rng));
        for (int a = 0; a < 3; ++a) x[3 * size_t(v) + a] = c[a] + rr * b.m.unit[3 * size_t(v) + a];
      }
      return x;
    };
    for (int trial = 0; trial < 30; ++trial) {
      CAPTURE(n);
      CAPTURE(trial);
      const double o[3] = {U(rng), U(rng), U(rng)};
      auto x = rough(10, o, 0.08);
      std::vector<std::vector<double>> ys;
      double c0[3] = {0, 0, 0};
      const int k = 1 + trial % 3;
      for (int j = 0; j < k; ++j) {
        double dir[3] = {U(rng), U(rng), U(rng)};
        const double l = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]) + 1e-12;
        const double d = 18.5 + 5 * U(rng);  // 13.5 .. 23.5 between centres of radii ~10 and ~8
        const double c[3] = {d * dir[0] / l, d * dir[1] / l, d * dir[2] / l};
        if (j == 0)
          for (int a = 0; a < 3; ++a) c0[a] = c[a];
        ys.push_back(rough(8, c, 0.08));
      }
      if (trial % 4 == 3) {
        // A spike of x towards the first obstacle's centre and past it.
        const uint32_t v = uint32_t(trial * 131) % nv;
        for (int a = 0; a < 3; ++a) x[3 * size_t(v) + a] = 1.3 * c0[a];
      }
      if (trial % 4 == 1) {
        // A spike of the first obstacle through x (its triangles too wide
        // for the grid's cells).
        const uint32_t v = uint32_t(trial * 71) % nv;
        for (int a = 0; a < 3; ++a) ys[0][3 * size_t(v) + a] = o[a] - 0.8 * c0[a];
      }
      std::vector<const std::vector<double>*> obst;
      std::vector<const double*> p;
      for (const auto& y : ys) {
        obst.push_back(&y);
        p.push_back(y.data());
      }
      // Every other case with a region: x's own box (the guard's use); only
      // the obstacles' faces there enter the grid.
      double region[6];
      for (int a = 0; a < 3; ++a) region[a] = region[3 + a] = x[a];
      for (uint32_t v = 0; v < nv; ++v)
        for (int a = 0; a < 3; ++a) {
          region[a] = std::fmin(region[a], x[3 * size_t(v) + a]);
          region[3 + a] = std::fmax(region[3 + a], x[3 * size_t(v) + a]);
        }
      ffseg::build_obstacles(b.m, p.data(), uint32_t(p.size()), b.cs, trial % 2 ? region : nullptr);
      std::vector<uint8_t> mark(nv, 0), ref;
      const uint32_t got = ffseg::mark_contacts(b.m, x.data(), b.cs, mark.data());
      const uint32_t want = brute_crossings(b.m, x, obst, ref);
      CHECK(got == want);
      CHECK(mark == ref);
      CHECK((ffseg::mark_contacts(b.m, x.data(), b.cs, nullptr) > 0) == (want > 0));
      crossing_cases += want > 0;
      clean_cases += want == 0;
    }
  }
  CHECK(crossing_cases >= 20);  // both kinds occur
  CHECK(clean_cases >= 10);
}

TEST_CASE("mesh contact: tracked calls after local moves equal the check from scratch") {
  // The guard's use: one set of obstacles, then a sequence of positions each
  // differing from the last at a patch of vertices (pushed into a neighbour,
  // pulled back, sometimes the whole mesh inside another's box); every
  // tracked call gives the count and the marks of the untracked one.
  std::mt19937_64 rng(30030);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  uint32_t crossing_calls = 0, clean_calls = 0;
  for (uint32_t n : {6u, 10u}) {
    ContactBox b(n, 3);
    const uint32_t nv = b.m.nv;
    const auto A = b.sphere(8, 19.5, 0, 0), B = b.sphere(6, -3, 17, 1), C = b.sphere(30, 0, 0, 0);
    for (int setup = 0; setup < 3; ++setup) {
      CAPTURE(n);
      CAPTURE(setup);
      std::vector<const double*> p = {A.data(), B.data()};
      if (setup == 2) p.push_back(C.data());  // a shell around all: x lies inside it
      auto x = b.sphere(10);
      double region[6] = {-40, -40, -40, 40, 40, 40};
      ffseg::build_obstacles(b.m, p.data(), uint32_t(p.size()), b.cs, setup == 1 ? region : nullptr);
      std::vector<uint8_t> moved(nv, 0), mark(nv), ref(nv);
      for (int call = 0; call < 40; ++call) {
        CAPTURE(call);
        const uint8_t* mv = nullptr;
        if (call > 0) {
          // A patch around a random vertex moves outwards or inwards.
          std::fill(moved.begin(), moved.end(), 0);
          const uint32_t c = uint32_t(rng() % nv);
          const double s = 1 + 0.6 * U(rng);
          const bool all = call % 8 == 0;  // back to the clean sphere
          for (uint32_t v = 0; v < nv; ++v) {
            if (all) {
              moved[v] = 1;
              for (int a = 0; a < 3; ++a) x[3 * size_t(v) + a] = 10 * b.m.unit[3 * size_t(v) + a];
              continue;
            }
            double d = 0;
            for (int a = 0; a < 3; ++a) {
              const double e = b.m.unit[3 * size_t(v) + a] - b.m.unit[3 * size_t(c) + a];
              d += e * e;
            }
            if (d > 0.3) continue;
            moved[v] = 1;
            for (int a = 0; a < 3; ++a) x[3 * size_t(v) + a] = 10 * s * b.m.unit[3 * size_t(v) + a];
          }
          mv = moved.data();
        }
        std::fill(mark.begin(), mark.end(), 0);
        const uint32_t got = ffseg::mark_contacts_tracked(b.m, x.data(), b.cs, mark.data(), mv);
        // The untracked check ends the tracking: on a copy of the scratch's
        // state it would not, so check against a fresh box.
        ContactBox r(n, 3);
        ffseg::build_obstacles(r.m, p.data(), uint32_t(p.size()), r.cs, setup == 1 ? region : nullptr);
        std::fill(ref.begin(), ref.end(), 0);
        const uint32_t want = ffseg::mark_contacts(r.m, x.data(), r.cs, ref.data());
        CHECK(got == want);
        CHECK(mark == ref);
        crossing_calls += want > 0;
        clean_calls += want == 0;
      }
    }
  }
  CHECK(crossing_calls >= 20);
  CHECK(clean_calls >= 5);
}

TEST_CASE("mesh contact: an obstacle's splits from its caller are taken where their key holds its corners") {
  ContactBox b(12, 1);
  const uint32_t nv = b.m.nv, nt = b.m.triangle_count();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.4, 0.4);
  auto B = b.sphere(10, 15, 0.5, -0.3);
  for (double& q : B) q += jitter(rng);  // non-planar quads, split either way
  const auto A = b.sphere(10);
  // The splits face_triangles() decides at B, and their opposites.
  std::vector<uint8_t> alt(b.m.nfaces), flipped(b.m.nfaces);
  uint32_t alts = 0;
  for (uint32_t f = 0; f < b.m.nfaces; ++f) {
    uint32_t got[6], zero[6];
    const int c = ffseg::face_triangles(b.m, f, got, B.data());
    ffseg::face_split(b.m, f, false, zero);
    alt[f] = c == 2 && (got[0] != zero[0] || got[3] != zero[3]);
    flipped[f] = c == 2 && !alt[f];
    alts += alt[f];
  }
  CHECK(alts > 0);
  const double* p[1] = {B.data()};
  auto build = [&](const ffseg::ObstacleSplits* splits) {
    ffseg::build_obstacles(b.m, p, 1, b.cs, nullptr, splits);
    return std::vector<uint32_t>(b.cs.tris, b.cs.tris + 3 * size_t(nt));
  };
  // Face f's triangles in a build's list.
  auto face = [&](const std::vector<uint32_t>& t, uint32_t f) {
    const size_t t0 = b.m.first_triangle(f), c = b.m.faces[4 * size_t(f) + 3] == ffseg::kNone ? 1 : 2;
    return std::vector<uint32_t>(t.begin() + 3 * t0, t.begin() + 3 * (t0 + c));
  };
  const auto plain = build(nullptr);
  std::vector<uint8_t> mark_plain, mark;
  const uint32_t count_plain = b.contacts(A, &mark_plain);
  CHECK(count_plain > 0);
  // Its own splits: the same triangles, the same contacts.
  const ffseg::ObstacleSplits own{alt.data(), B.data()};
  CHECK(build(&own) == plain);
  CHECK(b.contacts(A, &mark) == count_plain);
  CHECK(mark == mark_plain);
  // Other splits under its key are taken as given...
  const ffseg::ObstacleSplits other{flipped.data(), B.data()};
  const auto given = build(&other);
  CHECK(given != plain);
  // ...except on the faces around a vertex the key does not hold.
  auto moved = B;
  const uint32_t v = nv / 2;
  moved[3 * size_t(v)] += 1e-9;
  const ffseg::ObstacleSplits stale{flipped.data(), moved.data()};
  const auto partly = build(&stale);
  uint32_t around = 0;
  for (uint32_t f = 0; f < b.m.nfaces; ++f) {
    const uint32_t* q = b.m.faces + 4 * size_t(f);
    const bool at_v = q[0] == v || q[1] == v || q[2] == v || q[3] == v;
    around += at_v;
    CHECK(face(partly, f) == face(at_v ? plain : given, f));
  }
  CHECK(around > 0);
  const ffseg::ObstacleSplits none{nullptr, B.data()};
  CHECK(build(&none) == plain);
}
