// The engine's own self-intersection test (src/mesh/mesh_intersection.h) on
// the bare cube-sphere, with and without the patch certificate.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "cubesphere.h"
#include "diffusion.h"
#include "mesh_intersection.h"
#include "step_guard.h"
#include "support/sphere_box.h"
#include "test_util.h"
#include "testing.h"

using StageBox = ffseg_test::TriangleBox;


TEST_CASE("self-intersection test: a sphere is clean, a vertex pushed through the far side is caught") {
  StageBox b(12);
  std::vector<double> x = b.sphere(10);
  std::vector<uint8_t> mark(b.m.nv, 0);
  CHECK(ffseg::mark_intersections(b.m, x.data(), b.tri, mark.data()) == 0);
  // Push one vertex straight through the centre and out of the far side.
  const uint32_t v = b.m.nv / 3;
  for (int a = 0; a < 3; ++a) x[3 * v + a] = -12.0 * b.m.unit[3 * v + a];
  const uint32_t pairs = ffseg::mark_intersections(b.m, x.data(), b.tri, mark.data());
  CHECK(pairs > 0);
  CHECK(mark[v] == 1);
  CHECK(ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) >= 1);
}

TEST_CASE("self-intersection test: the patch certificate answers the yes/no query as the grid path does") {
  // Smooth, rough, bumped, flattened and folded spheres: the query with the
  // certificate (windows projected onto their mean normal, far clusters by
  // their boxes) against the plain grid path and against the marking call.
  std::mt19937_64 rng(4242);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  uint32_t certified_yes = 0, certified_no = 0, cases = 0, recorded_certified = 0;
  for (uint32_t n : {8u, 12u, 21u, 33u}) {
    StageBox b(n);
    const uint32_t nv = b.m.nv;
    const double edge = 10.0 * 1.57 / n;
    std::vector<uint8_t> mark(nv);
    for (int trial = 0; trial < 40; ++trial) {
      std::vector<double> x = b.sphere(10);
      const int kind = trial % 5;
      const double amp = 0.1 * (trial / 5 + 1);  // 0.1 .. 0.8
      const double k = 1 + trial % 7;
      for (uint32_t v = 0; v < nv; ++v) {
        double* p = &x[3 * size_t(v)];
        const double* u = &b.m.unit[3 * size_t(v)];
        if (kind == 0) {  // rough: radial noise of up to amp edges
          const double r = 10 + amp * edge * U(rng);
          for (int a = 0; a < 3; ++a) p[a] = r * u[a];
        } else if (kind == 1) {  // bumps, deep folds when amp is large
          const double r = 10 * (1 + amp * std::sin(k * 3 * u[0]) * std::sin(k * 3 * u[1]));
          for (int a = 0; a < 3; ++a) p[a] = r * u[a];
        } else if (kind == 2) {  // flattened onto itself
          p[2] *= std::pow(10.0, -1 - 2 * amp * 5);
        } else if (kind == 3) {  // the cap above z = h folded down by k times its height
          const double h = 10 * (0.2 + 0.5 * amp);
          if (p[2] > h) p[2] = h - (p[2] - h) * (0.5 + 0.4 * k);
        } else {  // tangential jitter of up to amp edges
          for (int a = 0; a < 3; ++a) p[a] += amp * edge * U(rng);
        }
      }
      if (trial % 3 == 0) {  // and one vertex pushed through the far side
        const uint32_t v = uint32_t(rng() % nv);
        for (int a = 0; a < 3; ++a) x[3 * size_t(v) + a] = -(12 + 4 * amp) * b.m.unit[3 * size_t(v) + a];
      }
      CAPTURE(n);
      CAPTURE(trial);
      ffseg::TriangleScratchTesting::use_certificate(b.tri, false);
      const bool plain = ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) > 0;
      const bool marked = ffseg::mark_intersections(b.m, x.data(), b.tri, mark.data()) > 0;
      ffseg::TriangleScratchTesting::use_certificate(b.tri, true);
      const uint32_t before = ffseg::TriangleScratchTesting::certified_calls(b.tri);
      const bool cert = ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) > 0;
      CHECK(plain == marked);
      CHECK(cert == plain);
      if (ffseg::TriangleScratchTesting::certified_calls(b.tri) > before) (cert ? certified_yes : certified_no) += 1;
      // The recorded check from scratch (the certificate finds its pairs
      // when it decides) marks what the marking call marked, with as many
      // pairs; so does a tracked call after one vertex moved.
      std::vector<uint8_t> want(nv, 0);
      const uint32_t npairs = ffseg::mark_intersections(b.m, x.data(), b.tri, want.data());
      std::vector<uint8_t> got(nv, 0);
      const uint32_t before_rec = ffseg::TriangleScratchTesting::certified_calls(b.tri);
      CHECK(ffseg::mark_intersections_tracked(b.m, x.data(), b.tri, got.data(), nullptr) == npairs);
      CHECK(got == want);
      recorded_certified += ffseg::TriangleScratchTesting::certified_calls(b.tri) > before_rec;
      const uint32_t w = uint32_t(rng() % nv);
      std::vector<uint8_t> moved(nv, 0);
      moved[w] = 1;
      for (int a = 0; a < 3; ++a) x[3 * size_t(w) + a] *= 0.9;
      std::fill(got.begin(), got.end(), 0);
      const uint32_t tracked = ffseg::mark_intersections_tracked(b.m, x.data(), b.tri, got.data(), moved.data());
      std::vector<uint8_t> fresh(nv, 0);
      CHECK(ffseg::mark_intersections(b.m, x.data(), b.tri, fresh.data()) == tracked);
      CHECK(got == fresh);
      ++cases;
    }
  }
  // The certificate decided both ways (most heavily folded cases are left
  // to the grid path: too many windows fail).
  CAPTURE(cases);
  CHECK(certified_no >= 15);
  CHECK(certified_yes >= 10);
  CHECK(recorded_certified >= 25);
  // A smooth sphere is certified outright at every size the guard meets.
  for (uint32_t n : {12u, 21u, 33u, 49u}) {
    CAPTURE(n);
    StageBox b(n);
    const std::vector<double> x = b.sphere(25);
    CHECK(ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) == 0);
    CHECK(ffseg::TriangleScratchTesting::certified_calls(b.tri) == 1);
    CHECK(b.tri.cert.nfailed <= b.tri.cert.ncl / 16);
  }
}
