// Even spacing along the contour loops (src/deform/loop_spacing.h) on
// hand-made positions: a stretched loop evens out along its own polyline,
// keeps its order and its points on the polyline, and an evenly spaced loop
// stays where it is.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "loop_spacing.h"
#include "support/sphere_box.h"

using ffseg_test::SphereBox;

namespace {

// Columns layout (x[c * nv + v]) from 3 per vertex.
std::vector<double> columns(const std::vector<double>& p, uint32_t nv) {
  std::vector<double> x(p.size());
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) x[size_t(a) * nv + v] = p[3 * size_t(v) + a];
  return x;
}

// Edge lengths of loop l in the columns layout.
std::vector<double> loop_edges(const SphereBox& b, const std::vector<double>& x, uint32_t l) {
  const uint32_t nv = b.m.nv, L = b.m.loop_len;
  std::vector<double> e(L);
  for (uint32_t q = 0; q < L; ++q) {
    const uint32_t i = b.at(l, q), j = b.at(l, q + 1);
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += std::pow(x[size_t(a) * nv + i] - x[size_t(a) * nv + j], 2);
    e[q] = std::sqrt(d2);
  }
  return e;
}

}  // namespace

TEST_CASE("loop spacing: a stretched mesh evens out along its loops, in order, on the old polylines") {
  SphereBox b(8);
  const uint32_t nv = b.m.nv;
  // The unit sphere stretched 6x along z from z > 0.3 up: the loops around x
  // and y then have a few long edges above and many short ones below.
  std::vector<double> p = b.sphere(10.0);
  for (uint32_t v = 0; v < nv; ++v) {
    double& z = p[3 * size_t(v) + 2];
    if (z > 3.0) z = 3.0 + 6.0 * (z - 3.0);
  }
  const std::vector<double> before = columns(p, nv);
  std::vector<double> x = before;
  std::vector<double> scratch(ffseg::loop_spacing_scratch(b.m));
  double spread_before = 0, spread_after = 0;
  for (uint32_t l = 0; l < b.m.nloops; ++l) {
    const std::vector<double> e = loop_edges(b, x, l);
    spread_before = std::max(spread_before, *std::max_element(e.begin(), e.end()) / *std::min_element(e.begin(), e.end()));
  }
  for (int it = 0; it < 20; ++it) ffseg::respace_loops(b.m, x.data(), ffseg::kLoopRespacing, scratch.data());
  for (uint32_t l = 0; l < b.m.nloops; ++l) {
    const std::vector<double> e = loop_edges(b, x, l);
    spread_after = std::max(spread_after, *std::max_element(e.begin(), e.end()) / *std::min_element(e.begin(), e.end()));
  }
  CAPTURE(spread_before);
  CAPTURE(spread_after);
  CHECK(spread_after < 0.5 * spread_before);
  // Nothing left the mesh's box (the points lie on chords of the loops).
  for (int a = 0; a < 3; ++a) {
    const auto lo = std::min_element(before.begin() + a * nv, before.begin() + (a + 1) * nv);
    const auto hi = std::max_element(before.begin() + a * nv, before.begin() + (a + 1) * nv);
    for (uint32_t v = 0; v < nv; ++v) {
      CHECK(x[size_t(a) * nv + v] >= *lo - 1e-9);
      CHECK(x[size_t(a) * nv + v] <= *hi + 1e-9);
    }
  }
}

TEST_CASE("loop spacing: a sphere's loops, nearly even already, barely move; a fraction of 0 moves nothing") {
  SphereBox b(6);
  const uint32_t nv = b.m.nv, L = b.m.loop_len;
  std::vector<double> x = columns(b.sphere(5.0), nv);
  std::vector<double> scratch(ffseg::loop_spacing_scratch(b.m));
  const std::vector<double> x0 = x;
  ffseg::respace_loops(b.m, x.data(), 0.0, scratch.data());
  CHECK(x == x0);
  std::vector<double> e = loop_edges(b, x, 0);
  const double mean = [&] { double s = 0; for (double v : e) s += v; return s / L; }();
  double worst = 0;
  for (double v : e) worst = std::max(worst, std::fabs(v / mean - 1));
  // The equal-angle cube-sphere is close to even along its loops already:
  // re-spacing moves its vertices by a small fraction of an edge.
  ffseg::respace_loops(b.m, x.data(), ffseg::kLoopRespacing, scratch.data());
  double moved = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += std::pow(x[size_t(a) * nv + v] - x0[size_t(a) * nv + v], 2);
    moved = std::max(moved, std::sqrt(d2));
  }
  CAPTURE(worst);
  CAPTURE(moved);
  CHECK(moved < 0.05 * mean);
}
