// Fold prevention (thesis 4.2.4, fig. 4.7; src/deform/fold_prevention.h): two
// vertices whose displacements disagree in direction and close in on each
// other have both displacements halved until they no longer reach, or until
// the pass budget is spent; vertices that agree, or move apart, keep theirs.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "fold_prevention.h"
#include "support/sphere_box.h"

using ffseg_test::ArenaBox;
using ffseg_test::SphereBox;

namespace {

struct FoldBox {
  SphereBox b;
  ffseg::IntersectionScratch s;
  ArenaBox box;
  std::vector<double> x, d;
  std::vector<uint8_t> has;
  explicit FoldBox(uint32_t n)
      : b(n), box([&](ffseg::Arena& a) { s.carve(a, b.m.nv); }), x(b.sphere(10)), d(size_t(3) * b.m.nv, 0.0),
        has(b.m.nv, 0) {
    REQUIRE(box.ok());
  }
  // Vertices i and j two apart along loop l (not neighbours).
  void pick(uint32_t l, uint32_t p, uint32_t* i, uint32_t* j) const {
    *i = b.at(l, p);
    *j = b.at(l, p + 2);
  }
  // d_i = s (u_j - u_i): towards (s > 0) or away from j.
  void aim(uint32_t i, uint32_t j, double s) {
    has[i] = 1;
    for (int a = 0; a < 3; ++a) d[3 * i + a] = s * (x[3 * j + a] - x[3 * i + a]);
  }
  uint32_t run(double tau = 0.0, double alpha = 1.0) {
    return ffseg::prevent_folds(b.m, x.data(), d.data(), has.data(), tau, alpha, s);
  }
};

}  // namespace

TEST_CASE("fold prevention: two vertices heading into each other are halved until they no longer reach") {
  FoldBox f(8);
  uint32_t i, j;
  f.pick(3, 5, &i, &j);
  // |d| = 1.5 D (D = |u_i - u_j|): u_j within reach; halved to 0.75 D, u_j's
  // own end point u_j + d_j (0.25 D from u_i) still is; at 0.375 D nothing is.
  f.aim(i, j, 1.5);
  f.aim(j, i, 1.5);
  const std::vector<double> d0 = f.d;
  CHECK(f.run() == 2);
  for (int a = 0; a < 3; ++a) {
    CHECK(f.d[3 * i + a] == d0[3 * i + a] / 4);
    CHECK(f.d[3 * j + a] == d0[3 * j + a] / 4);
  }
  // The same pair at alpha = 0.5: the step only takes half of each
  // displacement, so one halving less is needed.
  f.d = d0;
  CHECK(f.run(0.0, 0.5) == 2);
  for (int a = 0; a < 3; ++a) CHECK(f.d[3 * i + a] == d0[3 * i + a] / 2);
}

TEST_CASE("fold prevention: the pass budget ends the halving") {
  FoldBox f(8);
  uint32_t i, j;
  f.pick(3, 5, &i, &j);
  // |d| = 1000 D: still reaching after every one of the 8 passes' halvings.
  f.aim(i, j, 1000);
  f.aim(j, i, 1000);
  const std::vector<double> d0 = f.d;
  CHECK(f.run() == 2);
  for (int a = 0; a < 3; ++a) CHECK(f.d[3 * i + a] == d0[3 * i + a] / 256);
  for (int a = 0; a < 3; ++a) CHECK(f.d[3 * j + a] == d0[3 * j + a] / 256);
}

TEST_CASE("fold prevention: agreeing, diverging, neighbouring and solitary vertices are untouched") {
  FoldBox f(8);
  uint32_t i, j;
  f.pick(3, 5, &i, &j);
  SUBCASE("both move the same way (towards and past each other's side)") {
    f.aim(i, j, 1.5);
    f.has[j] = 1;
    for (int a = 0; a < 3; ++a) f.d[3 * j + a] = f.d[3 * i + a];
  }
  SUBCASE("opposite directions, moving apart") {
    f.aim(i, j, -1.5);
    f.aim(j, i, -1.5);
  }
  SUBCASE("disagreeing but only at right angles, tau = -0.5") {
    f.aim(i, j, 1.5);
    f.has[j] = 1;
    // d_j perpendicular to d_i (and to the sphere's normal at nothing in
    // particular): cos = 0 > tau.
    const double* di = &f.d[3 * i];
    const double* u = &f.b.m.unit[3 * j];
    double c[3] = {di[1] * u[2] - di[2] * u[1], di[2] * u[0] - di[0] * u[2], di[0] * u[1] - di[1] * u[0]};
    for (int a = 0; a < 3; ++a) f.d[3 * j + a] = c[a];
    const std::vector<double> d0 = f.d;
    CHECK(f.run(-0.5) == 0);
    CHECK(f.d == d0);
    return;
  }
  SUBCASE("neighbours heading into each other (the Laplacian's business, not a fold)") {
    j = f.b.m.nbr[4 * i];
    f.aim(i, j, 1.5);
    f.aim(j, i, 1.5);
  }
  SUBCASE("the other vertex has no displacement") {
    f.aim(i, j, 1.5);
    for (int a = 0; a < 3; ++a) f.d[3 * j + a] = -f.d[3 * i + a];  // ignored: has[j] = 0
  }
  const std::vector<double> d0 = f.d;
  CHECK(f.run() == 0);
  CHECK(f.d == d0);
}

TEST_CASE("fold prevention: only the conflicting pair is shortened among many moving vertices") {
  FoldBox f(8);
  const uint32_t nv = f.b.m.nv;
  // Everyone grows by 0.3 mm; one pair heads into each other. tau = -0.5: a
  // radial displacement and the pair's chord disagree by less than that.
  for (uint32_t v = 0; v < nv; ++v) {
    f.has[v] = 1;
    for (int a = 0; a < 3; ++a) f.d[3 * v + a] = 0.3 * f.b.m.unit[3 * v + a];
  }
  uint32_t i, j;
  f.pick(7, 9, &i, &j);
  f.aim(i, j, 1.5);
  f.aim(j, i, 1.5);
  const std::vector<double> d0 = f.d;
  CHECK(f.run(-0.5) == 2);
  for (uint32_t v = 0; v < nv; ++v) {
    if (v == i || v == j) continue;
    CAPTURE(v);
    for (int a = 0; a < 3; ++a) CHECK(f.d[3 * v + a] == d0[3 * v + a]);
  }
  for (int a = 0; a < 3; ++a) CHECK(f.d[3 * i + a] == d0[3 * i + a] / 4);
}

namespace {

// The rule of prevent_folds() written plainly: every pass, every vertex
// against every other vertex and target within alpha |d_i|, a fresh look at
// all points each pass. The grid, its cones of directions and its second
// grid for the moved targets must find exactly these conflicts.
uint32_t reference_folds(const ffseg::CubeSphere& m, const double* x, double* d, const uint8_t* has, double tau,
                         double alpha) {
  const uint32_t nv = m.nv;
  std::vector<uint8_t> ever(nv, 0), active(nv, 1);
  for (int pass = 0; pass < 8; ++pass) {
    double dsum = 0;
    std::vector<double> pts(6 * size_t(nv)), len(nv);
    for (uint32_t v = 0; v < nv; ++v) {
      double len2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double dv = has[v] ? alpha * d[3 * v + a] : 0.0;
        pts[3 * v + a] = x[3 * v + a];
        pts[3 * (nv + v) + a] = x[3 * v + a] + dv;
        len2 += dv * dv;
      }
      if (has[v]) dsum += std::sqrt(len2);
      len[v] = std::sqrt(d[3 * v] * d[3 * v] + d[3 * v + 1] * d[3 * v + 1] + d[3 * v + 2] * d[3 * v + 2]);
    }
    if (!(dsum > 0)) break;
    std::vector<uint8_t> now(nv, 0);
    bool any = false;
    for (uint32_t i = 0; i < nv; ++i) {
      if (!has[i] || !active[i] || !(len[i] > 0)) continue;
      const double* di = d + 3 * i;
      const double* ui = x + 3 * i;
      const double r = alpha * len[i], r2 = r * r;
      const uint32_t* nb = m.nbr + 4 * size_t(i);
      for (uint32_t id = 0; id < 2 * nv; ++id) {
        const double* q = pts.data() + 3 * size_t(id);
        const double dx = q[0] - ui[0], dy = q[1] - ui[1], dz = q[2] - ui[2];
        if (!(dx * dx + dy * dy + dz * dz <= r2)) continue;
        const uint32_t j = id < nv ? id : id - nv;
        if (j == i || !has[j] || j == nb[0] || j == nb[1] || j == nb[2] || j == nb[3] || !(len[j] > 0)) continue;
        const double* dj = d + 3 * j;
        const double* uj = x + 3 * j;
        if ((di[0] * dj[0] + di[1] * dj[1] + di[2] * dj[2]) / (len[i] * len[j]) > tau) continue;
        const double ahead = (q[0] - ui[0]) * di[0] + (q[1] - ui[1]) * di[1] + (q[2] - ui[2]) * di[2];
        const double closing = (di[0] - dj[0]) * (ui[0] - uj[0]) + (di[1] - dj[1]) * (ui[1] - uj[1]) +
                               (di[2] - dj[2]) * (ui[2] - uj[2]);
        if (ahead > 0 && closing < 0) now[i] = now[j] = 1, any = true;
      }
    }
    if (!any) break;
    for (uint32_t v = 0; v < nv; ++v) {
      active[v] = now[v];
      if (now[v]) {
        ever[v] = 1;
        for (int a = 0; a < 3; ++a) d[3 * v + a] *= 0.5;
      }
    }
  }
  uint32_t shortened = 0;
  for (uint32_t v = 0; v < nv; ++v) shortened += ever[v];
  return shortened;
}

}  // namespace

TEST_CASE("fold prevention: the same halvings as the rule applied to every pair") {
  // Smooth outward fields with a crumpled patch, noisy fields, fields
  // pushing one cap through the other side: many passes, many conflicts.
  std::mt19937_64 rng(30);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  uint32_t shortened = 0;
  for (uint32_t n : {6u, 10u}) {
    for (int trial = 0; trial < 12; ++trial) {
      FoldBox f(n);
      const uint32_t nv = f.b.m.nv;
      const double noise = 0.2 * (trial % 4), scale = 0.5 + 0.5 * (trial % 3);
      for (uint32_t v = 0; v < nv; ++v) {
        f.has[v] = (v + trial) % 9 != 0;
        const double* u = &f.b.m.unit[3 * size_t(v)];
        const double push = trial % 2 && u[2] > 0.6 ? -30.0 : 1.0;
        for (int a = 0; a < 3; ++a) f.d[3 * v + a] = scale * (push * u[a] + noise * 5 * U(rng));
      }
      std::vector<double> d_ref = f.d;
      const uint32_t want = reference_folds(f.b.m, f.x.data(), d_ref.data(), f.has.data(), 0.2, 0.5);
      CAPTURE(n);
      CAPTURE(trial);
      CHECK(f.run(0.2, 0.5) == want);
      shortened += want;
      CHECK(f.d == d_ref);
    }
  }
  CHECK(shortened > 2000);  // about 3,700 of the 9,792 vertices: many passes, many conflicts
}
