// Diffusion of displacements (thesis eq. 4.2.2 / 5.3.3) and the harmonic fill
// of target-less gaps (src/deform/diffusion.h) on known fields.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "diffusion.h"
#include "support/sphere_box.h"
#include "testing.h"

using ffseg_test::SphereBox;

namespace {

// Every diffusion kernel this CPU runs (portable, SSE2).
std::vector<ffseg::CpuDispatch> diffusion_kernels() {
  std::vector<ffseg::CpuDispatch> out;
  for (ffseg::Isa k : {ffseg::Isa::portable, ffseg::Isa::sse2})
    if (ffseg::CpuDispatch::supports(ffseg::KernelFamily::diffusion, k))
      out.push_back(ffseg::CpuDispatchTesting::with({}, ffseg::KernelFamily::diffusion, k));
  return out;
}

}  // namespace

TEST_CASE("diffusion: a constant field stays constant, with and without solitary vertices") {
  SphereBox b(7);
  const uint32_t nv = b.m.nv;
  const double c[3] = {0.75, -1.25, 2.5};  // sums of five of them divided by 5 are exact
  std::vector<double> tmp(size_t(3) * nv);
  std::vector<uint8_t> tmp_has(nv);
  for (const ffseg::CpuDispatch& cpu : diffusion_kernels())
  for (uint32_t rounds : {1u, 2u, 7u}) {
    CAPTURE(rounds);
    std::vector<double> d(size_t(3) * nv);
    std::vector<uint8_t> has(nv, 1);
    for (uint32_t v = 0; v < nv; ++v)
      for (int a = 0; a < 3; ++a) d[3 * v + a] = c[a];
    ffseg::diffuse_displacements(cpu, b.m, rounds, d.data(), has.data(), tmp.data(), tmp_has.data());
    for (uint32_t v = 0; v < nv; ++v)
      for (int a = 0; a < 3; ++a) CHECK(d[3 * v + a] == doctest::Approx(c[a]).epsilon(1e-14));
    // A cap without displacements: each round reaches one ring further into
    // it, with the same constant; what is not reached stays solitary.
    for (uint32_t v = 0; v < nv; ++v) has[v] = b.m.unit[3 * v + 2] < 0.2;
    const std::vector<uint8_t> has0 = has;
    ffseg::diffuse_displacements(cpu, b.m, rounds, d.data(), has.data(), tmp.data(), tmp_has.data());
    uint32_t gained = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      if (has0[v]) CHECK(has[v] == 1);
      gained += has[v] && !has0[v];
      if (has[v])
        for (int a = 0; a < 3; ++a) CHECK(d[3 * v + a] == doctest::Approx(c[a]).epsilon(1e-14));
    }
    CHECK(gained > 0);
    uint32_t all = 0;
    for (uint32_t v = 0; v < nv; ++v) all += has[v];
    if (rounds <= 2) CHECK(all < nv);  // one or two rounds do not reach the pole of an n = 7 cap
  }
}

TEST_CASE("diffusion: a checkerboard decays by 3/5 a round where its 2-ring alternates, keeping its sign after even rounds") {
  // The five-point mean of +1 among four -1 is -3/5: on a face's interior a
  // checkerboard is an eigenvector, one round flips and shrinks it, two
  // rounds leave 9/25 of it with its sign. (The cube's corner triangles make
  // the mesh non-bipartite, so only vertices whose 2-ring alternates count.)
  SphereBox b(9);
  const uint32_t nv = b.m.nv;
  std::vector<double> s(nv);
  for (uint32_t v = 0; v < nv; ++v) {
    int32_t P[3];
    b.m.coords_of(v, P);
    s[v] = (((P[0] + P[1] + P[2] + 3 * 9) / 2) % 2) ? 1.0 : -1.0;
  }
  auto alternates = [&](uint32_t v) {
    for (int k = 0; k < 4; ++k)
      if (s[b.m.nbr[4 * v + k]] != -s[v]) return false;
    return true;
  };
  std::vector<uint8_t> ring2(nv, 0);
  uint32_t good = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    bool ok = alternates(v);
    for (int k = 0; k < 4 && ok; ++k) ok = alternates(b.m.nbr[4 * v + k]);
    ring2[v] = ok;
    good += ok;
  }
  REQUIRE(good > nv / 3);
  std::vector<double> tmp(size_t(3) * nv);
  std::vector<uint8_t> tmp_has(nv);
  const double amp[3] = {1.0, -0.5, 2.0};
  double energy0 = 0;
  std::vector<double> d0(size_t(3) * nv);
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) {
      d0[3 * v + a] = amp[a] * s[v];
      energy0 += d0[3 * v + a] * d0[3 * v + a];
    }
  for (const ffseg::CpuDispatch& cpu : diffusion_kernels())
  for (uint32_t rounds : {1u, 2u, 4u}) {
    CAPTURE(rounds);
    std::vector<double> d = d0;
    std::vector<uint8_t> has(nv, 1);
    ffseg::diffuse_displacements(cpu, b.m, rounds, d.data(), has.data(), tmp.data(), tmp_has.data());
    const double f = std::pow(-0.6, double(rounds));
    double energy = 0;
    for (uint32_t v = 0; v < nv; ++v)
      for (int a = 0; a < 3; ++a) energy += d[3 * v + a] * d[3 * v + a];
    CHECK(energy < 0.4 * energy0 * std::pow(0.6, 2.0 * (rounds - 1)));
    if (rounds > 2) continue;  // the exact factor needs the 2-ring only for two rounds
    for (uint32_t v = 0; v < nv; ++v) {
      if (!ring2[v]) continue;
      CAPTURE(v);
      for (int a = 0; a < 3; ++a) CHECK(d[3 * v + a] == doctest::Approx(f * d0[3 * v + a]).epsilon(1e-12));
    }
  }
}

TEST_CASE("harmonic fill: a one-vertex gap gets its neighbours' mean; nothing to extend from fills nothing") {
  SphereBox b(6);
  const uint32_t nv = b.m.nv;
  std::mt19937_64 rng(15);
  std::uniform_real_distribution<double> U(-2.0, 2.0);
  std::vector<double> d(size_t(3) * nv);
  for (auto& q : d) q = U(rng);
  std::vector<uint8_t> has(nv, 1);
  std::vector<uint32_t> queue(nv);
  const uint32_t g = b.at(2, 7);
  has[g] = 0;
  std::vector<double> d0 = d;
  CHECK(ffseg::harmonic_fill(b.m, d.data(), has.data(), queue.data(), 50, 1e-12) == 1);
  CHECK(has[g] == 1);
  for (int a = 0; a < 3; ++a) {
    double mean = 0;
    for (int k = 0; k < 4; ++k) mean += 0.25 * d0[3 * b.m.nbr[4 * g + k] + a];
    CHECK(d[3 * g + a] == doctest::Approx(mean).epsilon(1e-12));
  }
  for (uint32_t v = 0; v < nv; ++v)
    if (v != g)
      for (int a = 0; a < 3; ++a) CHECK(d[3 * v + a] == d0[3 * v + a]);  // the fixed ones stay
  // Two adjacent gap vertices: each is the mean of its four neighbours (one
  // of them the other gap vertex), a 2x2 linear system solved by the sweeps.
  d = d0;
  const uint32_t h = b.m.nbr[4 * g];
  for (uint32_t v = 0; v < nv; ++v) has[v] = v != g && v != h;
  CHECK(ffseg::harmonic_fill(b.m, d.data(), has.data(), queue.data(), 200, 1e-13) == 2);
  for (uint32_t v : {g, h})
    for (int a = 0; a < 3; ++a) {
      double mean = 0;
      for (int k = 0; k < 4; ++k) mean += 0.25 * d[3 * b.m.nbr[4 * v + k] + a];
      CHECK(d[3 * v + a] == doctest::Approx(mean).epsilon(1e-10));
    }
  // No vertex has a displacement: there is nothing to extend.
  for (uint32_t v = 0; v < nv; ++v) has[v] = 0;
  CHECK(ffseg::harmonic_fill(b.m, d.data(), has.data(), queue.data(), 50, 1e-12) == 0);
  for (uint32_t v = 0; v < nv; ++v) CHECK(has[v] == 0);
}
