// Diffusion kernels against the portable rounds, and the harmonic fill of
// target-less gaps on spheres (src/deform/diffusion.h).
#include <doctest/doctest.h>

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
