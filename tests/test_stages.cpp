// Unit tests of single deformation stages on the bare cube-sphere: the
// harmonic fill of target-less gaps, the engine's own self-intersection test
// and the step guard that uses it.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "cubesphere.h"
#include "diffusion.h"
#include "mesh_intersection.h"
#include "step_guard.h"
#include "test_util.h"
#include "testing.h"

using ffseg_test::ArenaBox;

namespace {

struct StageBox {
  ffseg::CubeSphere m;
  ffseg::TriangleScratch tri;
  ArenaBox box;
  explicit StageBox(uint32_t n)
      : box([&](ffseg::Arena& a) {
          m.carve(a, n);
          tri.carve(a, m);
        }) {
    REQUIRE(box.ok());
    m.build();
  }
  // Positions of the sphere of radius r around the origin.
  std::vector<double> sphere(double r) const {
    std::vector<double> x(size_t(3) * m.nv);
    for (size_t q = 0; q < x.size(); ++q) x[q] = r * m.unit[q];
    return x;
  }
};

}  // namespace

TEST_CASE("diffusion: every kernel gives the portable rounds bit for bit (all displaced, and with gaps)") {
  StageBox b(13);
  const uint32_t nv = b.m.nv;
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> U(-3.0, 3.0);
  std::vector<double> d0(size_t(3) * nv);
  for (double& v : d0) v = U(rng);
  for (bool gaps : {false, true}) {
    std::vector<uint8_t> has0(nv, 1);
    if (gaps)
      for (uint32_t v = 0; v < nv; v += 7) has0[v] = 0;
    std::vector<double> ref;
    std::vector<uint8_t> ref_has;
    for (ffseg::Isa k : {ffseg::Isa::portable, ffseg::Isa::sse2}) {
      if (!ffseg::CpuDispatch::supports(ffseg::KernelFamily::diffusion, k)) continue;
      CAPTURE(gaps);
      CAPTURE(ffseg::CpuDispatch::name(k));
      const ffseg::CpuDispatch cpu = ffseg::CpuDispatchTesting::with({}, ffseg::KernelFamily::diffusion, k);
      std::vector<double> d = d0, tmp(d.size());
      std::vector<uint8_t> has = has0, tmp_has(nv);
      ffseg::diffuse_displacements(cpu, b.m, 5, d.data(), has.data(), tmp.data(), tmp_has.data());
      if (ref.empty()) {
        ref = d;
        ref_has = has;
        continue;
      }
      CHECK(std::memcmp(d.data(), ref.data(), d.size() * sizeof(double)) == 0);
      CHECK(has == ref_has);
    }
  }
}

TEST_CASE("harmonic fill: a gap inside a constant displacement gets that constant") {
  StageBox b(9);
  const uint32_t nv = b.m.nv;
  std::vector<double> d(size_t(3) * nv, 0.0);
  std::vector<uint8_t> has(nv);
  std::vector<uint32_t> queue(nv);
  uint32_t gap = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    has[v] = b.m.unit[3 * v + 2] < 0.4;  // the cap above z = 0.4 has no target
    gap += !has[v];
    if (has[v]) {
      d[3 * v] = 1.5;
      d[3 * v + 1] = -2;
      d[3 * v + 2] = 0.25;
    }
  }
  REQUIRE(gap > 20);
  const uint32_t filled = ffseg::harmonic_fill(b.m, d.data(), has.data(), queue.data(), 200, 1e-9);
  CHECK(filled == gap);
  for (uint32_t v = 0; v < nv; ++v) {
    CHECK(has[v] == 1);
    CHECK(d[3 * v] == doctest::Approx(1.5).epsilon(1e-6));
    CHECK(d[3 * v + 1] == doctest::Approx(-2).epsilon(1e-6));
    CHECK(d[3 * v + 2] == doctest::Approx(0.25).epsilon(1e-6));
  }
}

TEST_CASE("harmonic fill: a rim closing in fills the cap with a contraction that never crosses the axis") {
  // The cup's lid: the rim moves towards the z axis and down, the cap above
  // it has no target. Copying the rim's sideways motion inwards (plain
  // diffusion) moves the vertices near the pole across the axis; the
  // harmonic extension shrinks the cap instead.
  StageBox b(21);
  const uint32_t nv = b.m.nv;
  const std::vector<double> x = b.sphere(30);
  std::vector<double> d(size_t(3) * nv, 0.0);
  std::vector<uint8_t> has(nv);
  std::vector<uint32_t> queue(nv);
  const double pull = 0.6;  // the rim moves 60 % of the way to the axis
  for (uint32_t v = 0; v < nv; ++v) {
    has[v] = b.m.unit[3 * v + 2] < 0.6;
    if (has[v]) {
      d[3 * v] = -pull * x[3 * v];
      d[3 * v + 1] = -pull * x[3 * v + 1];
      d[3 * v + 2] = -5;
    }
  }
  ffseg::harmonic_fill(b.m, d.data(), has.data(), queue.data(), 400, 1e-9);
  uint32_t pole = 0;
  for (uint32_t v = 0; v < nv; ++v)
    if (b.m.unit[3 * v + 2] > b.m.unit[3 * pole + 2]) pole = v;
  const double rho_pole = std::hypot(x[3 * pole], x[3 * pole + 1]);
  const double lat_pole = std::hypot(d[3 * pole], d[3 * pole + 1]);
  CHECK(lat_pole <= pull * rho_pole + 1e-9);  // the pole moves less than the rim's rate
  for (uint32_t v = 0; v < nv; ++v) {
    const double px = x[3 * v], py = x[3 * v + 1];
    if (b.m.unit[3 * v + 2] < 0.6 || std::hypot(px, py) < 1e-9) continue;  // the rim, or on the axis
    CAPTURE(v);
    const double qx = px + d[3 * v], qy = py + d[3 * v + 1];
    // Inwards, but not across the axis: the new lateral position keeps its
    // direction and is no farther out.
    CHECK(qx * px + qy * py > 0);
    CHECK(std::hypot(qx, qy) <= std::hypot(px, py) + 1e-9);
    CHECK(d[3 * v + 2] == doctest::Approx(-5).epsilon(1e-6));
  }
}

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

TEST_CASE("step guard: a step that would cross is held back where it crosses, the rest moves in full") {
  // The guard first scales the whole update by 1, 1/2, 1/4; when even a
  // quarter would cross, only the region around the offender backs off.
  StageBox b(12);
  const uint32_t nv = b.m.nv;
  const std::vector<double> x_old = b.sphere(10);
  // Proposal: every vertex 1 mm outward; one vertex 50 mm through the far side
  // (a quarter of that still crosses).
  const uint32_t bad = nv / 3;
  std::vector<double> x_new(size_t(3) * nv);
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      x_new[size_t(a) * nv + v] = (v == bad ? -50.0 : 11.0) * b.m.unit[3 * v + a];
  std::vector<double> xs(size_t(3) * nv), share(nv);
  std::vector<uint8_t> mark(nv), grow(nv);
  const double kept = ffseg::guard_step(b.m, x_old.data(), x_new.data(), xs.data(), share.data(), mark.data(),
                                        grow.data(), b.tri);
  CAPTURE(kept);
  CHECK(kept < 1.0);
  CHECK(kept > 0.5);  // one region backs off, not the whole mesh
  std::vector<double> out(size_t(3) * nv);
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) out[3 * v + a] = x_new[size_t(a) * nv + v];
  CHECK(ffseg::mark_intersections(b.m, out.data(), b.tri, nullptr) == 0);
  CHECK(ffseg::mark_violations(b.m, x_old.data(), out.data(), nullptr) == 0);
  // A vertex a quarter turn away from the offender (its path and the spot
  // where it would come out are both far) moved its full millimetre.
  uint32_t far = 0;
  double best = 1e300;
  for (uint32_t v = 0; v < nv; ++v) {
    double dot = 0;
    for (int a = 0; a < 3; ++a) dot += b.m.unit[3 * v + a] * b.m.unit[3 * bad + a];
    if (std::fabs(dot) < best) { best = std::fabs(dot); far = v; }
  }
  double r = 0;
  for (int a = 0; a < 3; ++a) r += out[3 * far + a] * out[3 * far + a];
  CAPTURE(far);
  CAPTURE(share[far]);
  CHECK(std::sqrt(r) == doctest::Approx(11.0).epsilon(1e-9));
  // The offender did not go through.
  double dot = 0;
  for (int a = 0; a < 3; ++a) dot += out[3 * bad + a] * b.m.unit[3 * bad + a];
  CHECK(dot > 0);
}

TEST_CASE("step guard: the last step's fold-test cache, swapped in at its accepted positions, changes nothing") {
  // One scratch kept across steps (the cache of the accepted positions is
  // reused as the next step's old one) against a scratch told each time that
  // it has nothing to reuse: the same shares and positions bit for bit, over
  // steps that pass whole, back off locally and back off entirely.
  StageBox a(12), b(12);
  const uint32_t nv = a.m.nv;
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<double> x = a.sphere(10);
  std::vector<double> xs(size_t(3) * nv), share(nv), xs2(size_t(3) * nv), share2(nv);
  std::vector<uint8_t> mark(nv), grow(nv), mark2(nv), grow2(nv);
  uint32_t backed_off = 0;
  for (int step = 0; step < 12; ++step) {
    CAPTURE(step);
    std::vector<double> prop(size_t(3) * nv);
    const uint32_t bad = step % 3 == 1 ? uint32_t(step * 37) % nv : nv;  // every third: one vertex through
    for (uint32_t v = 0; v < nv; ++v)
      for (int c = 0; c < 3; ++c)
        prop[size_t(c) * nv + v] = v == bad ? -5.0 * x[3 * v + c] : x[3 * v + c] + 0.3 * U(rng);
    std::vector<double> p1 = prop, p2 = prop;
    b.tri.new_key_valid = false;
    const double k1 = ffseg::guard_step(a.m, x.data(), p1.data(), xs.data(), share.data(), mark.data(), grow.data(),
                                        a.tri);
    const double k2 = ffseg::guard_step(b.m, x.data(), p2.data(), xs2.data(), share2.data(), mark2.data(),
                                        grow2.data(), b.tri);
    CHECK(k1 == k2);
    CHECK(share == share2);
    REQUIRE(p1 == p2);
    backed_off += k1 < 1.0;
    for (uint32_t v = 0; v < nv; ++v)
      for (int c = 0; c < 3; ++c) x[3 * v + c] = p1[size_t(c) * nv + v];
    CHECK(ffseg::mark_intersections(a.m, x.data(), a.tri, nullptr) == 0);
  }
  CHECK(backed_off >= 3);
  CHECK(a.tri.reused_old_cache >= 6);  // swapped in on most steps
  CHECK(b.tri.reused_old_cache == 0);
}

TEST_CASE("self-intersection test: the patch certificate answers the yes/no query as the grid path does") {
  // Smooth, rough, bumped, flattened and folded spheres: the query with the
  // certificate (windows projected onto their mean normal, far clusters by
  // their boxes) against the plain grid path and against the marking call.
  std::mt19937_64 rng(4242);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  uint32_t certified_yes = 0, certified_no = 0, cases = 0;
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
      b.tri.use_certificate = false;
      const bool plain = ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) > 0;
      const bool marked = ffseg::mark_intersections(b.m, x.data(), b.tri, mark.data()) > 0;
      b.tri.use_certificate = true;
      const uint32_t before = b.tri.certified_calls;
      const bool cert = ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) > 0;
      CHECK(plain == marked);
      CHECK(cert == plain);
      if (b.tri.certified_calls > before) (cert ? certified_yes : certified_no) += 1;
      ++cases;
    }
  }
  // The certificate decided both ways (most heavily folded cases are left
  // to the grid path: too many windows fail).
  CAPTURE(cases);
  CHECK(certified_no >= 15);
  CHECK(certified_yes >= 10);
  // A smooth sphere is certified outright at every size the guard meets.
  for (uint32_t n : {12u, 21u, 33u, 49u}) {
    CAPTURE(n);
    StageBox b(n);
    const std::vector<double> x = b.sphere(25);
    CHECK(ffseg::mark_intersections(b.m, x.data(), b.tri, nullptr) == 0);
    CHECK(b.tri.certified_calls == 1);
    CHECK(b.tri.cert.nfailed <= b.tri.cert.ncl / 16);
  }
}
