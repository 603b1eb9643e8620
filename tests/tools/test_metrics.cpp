// Tests for tools/report/metrics.*: EDT against brute force, overlap and surface
// distance metrics on masks with known answers.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "metrics.h"

namespace {

using ffseg_tools::SegMetrics;

std::size_t nvox(const int d[3]) { return std::size_t(d[0]) * std::size_t(d[1]) * std::size_t(d[2]); }

std::size_t lin(const int d[3], int i, int j, int k) {
  return std::size_t(i) + std::size_t(d[0]) * (std::size_t(j) + std::size_t(d[1]) * std::size_t(k));
}

double brute_sq(const std::vector<uint8_t>& m, const int d[3], const double s[3], int i, int j, int k,
                bool nonzero) {
  double best = std::numeric_limits<double>::infinity();
  for (int z = 0; z < d[2]; ++z)
    for (int y = 0; y < d[1]; ++y)
      for (int x = 0; x < d[0]; ++x)
        if ((m[lin(d, x, y, z)] != 0) == nonzero) {
          const double dx = (x - i) * s[0], dy = (y - j) * s[1], dz = (z - k) * s[2];
          best = std::min(best, dx * dx + dy * dy + dz * dz);
        }
  return best;
}

std::vector<uint8_t> brute_border(const std::vector<uint8_t>& m, const int d[3]) {
  std::vector<uint8_t> b(m.size(), 0);
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i) {
        if (!m[lin(d, i, j, k)]) continue;
        bool border = false;
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const int x = i + di, y = j + dj, z = k + dk;
              if (x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2] || !m[lin(d, x, y, z)])
                border = true;
            }
        b[lin(d, i, j, k)] = border;
      }
  return b;
}

// Brute-force surface distance set (both directions) between two non-empty masks.
std::vector<double> brute_surface_distances(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b,
                                            const int d[3], const double s[3]) {
  const auto ba = brute_border(a, d), bb = brute_border(b, d);
  std::vector<double> out;
  for (int dir = 0; dir < 2; ++dir) {
    const auto& from = dir ? bb : ba;
    const auto& to = dir ? ba : bb;
    for (int k = 0; k < d[2]; ++k)
      for (int j = 0; j < d[1]; ++j)
        for (int i = 0; i < d[0]; ++i)
          if (from[lin(d, i, j, k)]) out.push_back(std::sqrt(brute_sq(to, d, s, i, j, k, true)));
  }
  return out;
}

std::vector<uint8_t> ball(const int d[3], double ci, double cj, double ck, double r) {
  std::vector<uint8_t> m(nvox(d), 0);
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i) {
        const double x = i - ci, y = j - cj, z = k - ck;
        m[lin(d, i, j, k)] = x * x + y * y + z * z <= r * r;
      }
  return m;
}

std::vector<uint8_t> box(const int d[3], int i0, int i1, int j0, int j1, int k0, int k1) {  // inclusive
  std::vector<uint8_t> m(nvox(d), 0);
  for (int k = k0; k <= k1; ++k)
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) m[lin(d, i, j, k)] = 1;
  return m;
}

}  // namespace

TEST_CASE("metrics: EDT equals brute force on random anisotropic grids") {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> dim(1, 9);
  std::uniform_real_distribution<double> sp(0.3, 2.5), u01(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int d[3] = {dim(rng), dim(rng), dim(rng)};
    const double s[3] = {sp(rng), sp(rng), sp(rng)};
    const double density = trial % 10 == 0 ? 0.0 : u01(rng) * 0.5;  // some empty sets
    std::vector<uint8_t> m(nvox(d));
    for (auto& v : m) v = u01(rng) < density ? uint8_t(1 + rng() % 255) : 0;
    for (bool nonzero : {true, false}) {
      const auto e2 = ffseg_tools::edt_sq_mm2(m.data(), d, s, nonzero);
      const auto e = ffseg_tools::edt_mm(m.data(), d, s, nonzero);
      REQUIRE(e2.size() == m.size());
      for (int k = 0; k < d[2]; ++k)
        for (int j = 0; j < d[1]; ++j)
          for (int i = 0; i < d[0]; ++i) {
            const double ref = brute_sq(m, d, s, i, j, k, nonzero);
            const std::size_t p = lin(d, i, j, k);
            if (std::isinf(ref)) {
              CHECK(std::isinf(e2[p]));
              CHECK(std::isinf(e[p]));
            } else {
              CHECK(std::fabs(e2[p] - ref) <= 1e-9);
              CHECK(std::fabs(e[p] - std::sqrt(ref)) <= 1e-9);
            }
            ++checked;
          }
    }
  }
  CHECK(checked > 1000);
}

TEST_CASE("metrics: EDT on a larger grid, distance to the border of a label") {
  const int d[3] = {21, 17, 13};
  const double s[3] = {0.8, 1.3, 2.1};
  const auto m = box(d, 2, 18, 3, 13, 1, 11);
  const auto e = ffseg_tools::edt_mm(m.data(), d, s, /*target_nonzero=*/false);  // distance to background
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i) {
        const std::size_t p = lin(d, i, j, k);
        if (!m[p]) {
          CHECK(e[p] == 0.0);
          continue;
        }
        // inside a box the nearest background voxel is straight through the nearest face
        const double ref = std::min({(std::min(i - 1, 19 - i)) * s[0], (std::min(j - 2, 14 - j)) * s[1],
                                     (std::min(k - 0, 12 - k)) * s[2]});
        CHECK(e[p] == doctest::Approx(ref).epsilon(1e-12));
      }
}

TEST_CASE("metrics: Dice, VOE, RVD and volumes on hand-counted masks") {
  const int d[3] = {5, 2, 1};
  const double s[3] = {0.5, 2.0, 1.0};  // 1 mm^3 voxels
  // A: 4 voxels, B: 6 voxels, A∩B: 3, A∪B: 7
  const std::vector<uint8_t> a = {1, 1, 1, 1, 0, 0, 0, 0, 0, 0};
  const std::vector<uint8_t> b = {0, 7, 1, 1, 1, 1, 1, 0, 0, 0};
  const SegMetrics m = ffseg_tools::compare_masks(a.data(), b.data(), d, s);
  CHECK(m.dice == doctest::Approx(6.0 / 10.0));
  CHECK(m.voe == doctest::Approx(1.0 - 3.0 / 7.0));
  CHECK(m.rvd == doctest::Approx((4.0 - 6.0) / 6.0));
  CHECK(m.vol_a_ml == doctest::Approx(0.004));
  CHECK(m.vol_b_ml == doctest::Approx(0.006));
  CHECK(m.border_a == 4);  // every voxel of a one-voxel-thick mask is border
  CHECK(m.border_b == 6);
  // disjoint masks
  const std::vector<uint8_t> c = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1};
  const SegMetrics mc = ffseg_tools::compare_masks(a.data(), c.data(), d, s);
  CHECK(mc.dice == 0.0);
  CHECK(mc.voe == 1.0);
  CHECK(std::isfinite(mc.hd_mm));
}

TEST_CASE("metrics: identical masks") {
  const int d[3] = {24, 20, 16};
  const double s[3] = {0.7, 0.9, 2.5};
  const auto m = ball(d, 11.5, 9.7, 7.2, 6.3);
  const SegMetrics r = ffseg_tools::compare_masks(m.data(), m.data(), d, s);
  CHECK(r.dice == 1.0);
  CHECK(r.voe == 0.0);
  CHECK(r.rvd == 0.0);
  CHECK(r.assd_mm == 0.0);
  CHECK(r.hd95_mm == 0.0);
  CHECK(r.hd_mm == 0.0);
  CHECK(r.border_a == r.border_b);
  CHECK(r.border_a > 0);
}

TEST_CASE("metrics: empty masks follow the documented convention") {
  const int d[3] = {4, 4, 4};
  const double s[3] = {1, 1, 1};
  const std::vector<uint8_t> z(64, 0);
  const auto a = box(d, 1, 2, 1, 2, 1, 2);
  const SegMetrics both = ffseg_tools::compare_masks(z.data(), z.data(), d, s);
  CHECK(both.dice == 1.0);
  CHECK(both.voe == 0.0);
  CHECK(both.assd_mm == 0.0);
  CHECK(both.border_a == 0);
  const SegMetrics ea = ffseg_tools::compare_masks(z.data(), a.data(), d, s);
  CHECK(ea.dice == 0.0);
  CHECK(ea.voe == 1.0);
  CHECK(ea.rvd == -1.0);
  CHECK(std::isinf(ea.assd_mm));
  CHECK(std::isinf(ea.hd95_mm));
  CHECK(std::isinf(ea.hd_mm));
  const SegMetrics eb = ffseg_tools::compare_masks(a.data(), z.data(), d, s);
  CHECK(eb.dice == 0.0);
  CHECK(std::isinf(eb.rvd));
  CHECK(std::isinf(eb.hd_mm));
  std::array<int, 3> ijk{};
  double dist = 0;
  CHECK_FALSE(ffseg_tools::find_deepest_voxel(z.data(), d, s, &ijk, &dist));
  const auto e = ffseg_tools::edt_mm(z.data(), d, s);
  CHECK(std::isinf(e[0]));
}

// With the 26-neighbour border definition the border layer is up to sqrt(3)
// voxels thick on oblique parts of the surface, so the two layers are less than
// 2 voxels apart there: the ASSD of concentric balls settles near 1.60 voxels
// for any radius (a 6-neighbour border would give about 1.92). HD95 is
// sqrt(5) and HD sqrt(6) voxels.
TEST_CASE("metrics: concentric balls of radii r and r+2 have ASSD about 2 voxels") {
  const int d[3] = {41, 41, 41};
  const auto inner = ball(d, 20, 20, 20, 10), outer = ball(d, 20, 20, 20, 12);
  const double s1[3] = {1, 1, 1};
  const SegMetrics m = ffseg_tools::compare_masks(inner.data(), outer.data(), d, s1);
  MESSAGE("balls r=10/12: ASSD " << m.assd_mm << " HD95 " << m.hd95_mm << " HD " << m.hd_mm);
  CHECK(m.assd_mm > 1.5);
  CHECK(m.assd_mm < 2.1);
  CHECK(m.hd95_mm >= 2.0);
  CHECK(m.hd95_mm <= 2.5);
  CHECK(m.hd_mm >= m.hd95_mm);
  CHECK(m.rvd < 0);
  // isotropic spacing scales every distance exactly
  const double s2[3] = {0.7, 0.7, 0.7};
  const SegMetrics m2 = ffseg_tools::compare_masks(inner.data(), outer.data(), d, s2);
  CHECK(m2.assd_mm == doctest::Approx(0.7 * m.assd_mm).epsilon(1e-12));
  CHECK(m2.hd95_mm == doctest::Approx(0.7 * m.hd95_mm).epsilon(1e-12));
  CHECK(m2.hd_mm == doctest::Approx(0.7 * m.hd_mm).epsilon(1e-12));
  CHECK(m2.dice == m.dice);
  CHECK(m2.vol_b_ml == doctest::Approx(m.vol_b_ml * 0.343).epsilon(1e-12));
}

TEST_CASE("metrics: shifted cube has the known surface distances") {
  const int d[3] = {32, 30, 30};
  const auto a = box(d, 10, 19, 10, 19, 10, 19);  // 10^3 cube
  const auto b = box(d, 12, 21, 10, 19, 10, 19);  // shifted by 2 voxels along i
  for (double sx : {0.5, 1.0, 3.0}) {
    const double s[3] = {sx, 1.0, 1.0};
    const SegMetrics m = ffseg_tools::compare_masks(a.data(), b.data(), d, s);
    CHECK(m.dice == doctest::Approx(0.8));           // 2*800 / 2000
    CHECK(m.voe == doctest::Approx(1.0 - 800.0 / 1200.0));
    CHECK(m.rvd == 0.0);
    CHECK(m.border_a == 1000 - 512);                 // 10^3 minus the 8^3 interior
    CHECK(m.border_b == 488);
    // the farthest border voxels are on the end faces: 2 voxels along i
    CHECK(m.hd_mm == doctest::Approx(2.0 * sx).epsilon(1e-12));
    // against brute force
    const auto ref = brute_surface_distances(a, b, d, s);
    double sum = 0;
    for (double v : ref) sum += v;
    std::vector<double> sorted = ref;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t rank = (95 * sorted.size() + 99) / 100;
    CHECK(m.assd_mm == doctest::Approx(sum / double(ref.size())).epsilon(1e-12));
    CHECK(m.hd95_mm == doctest::Approx(sorted[rank - 1]).epsilon(1e-12));
  }
  // pure translation by sx along i, spacing 1: the x = 10 face of A is 2 mm from B
  const double s1[3] = {1, 1, 1};
  const SegMetrics m1 = ffseg_tools::compare_masks(a.data(), b.data(), d, s1);
  CHECK(m1.hd95_mm == doctest::Approx(2.0));
}

TEST_CASE("metrics: compare_masks equals brute force on random masks") {
  std::mt19937 rng(777);
  std::uniform_int_distribution<int> dim(1, 8);
  std::uniform_real_distribution<double> sp(0.4, 2.2), u01(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const int d[3] = {dim(rng), dim(rng), dim(rng)};
    const double s[3] = {sp(rng), sp(rng), sp(rng)};
    const std::size_t n = nvox(d);
    std::vector<uint8_t> a(n), b(n);
    const double pa = 0.2 + 0.7 * u01(rng), pb = 0.2 + 0.7 * u01(rng);
    for (std::size_t i = 0; i < n; ++i) {
      a[i] = u01(rng) < pa;
      b[i] = u01(rng) < pb;
    }
    a[0] = 1;  // non-empty
    b[n - 1] = 1;
    const SegMetrics m = ffseg_tools::compare_masks(a.data(), b.data(), d, s);
    const auto ref = brute_surface_distances(a, b, d, s);
    REQUIRE(ref.size() == m.border_a + m.border_b);
    double sum = 0, mx = 0;
    for (double v : ref) {
      sum += v;
      mx = std::max(mx, v);
    }
    std::vector<double> sorted = ref;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t rank = (95 * sorted.size() + 99) / 100;
    CHECK(std::fabs(m.assd_mm - sum / double(ref.size())) <= 1e-9);
    CHECK(std::fabs(m.hd_mm - mx) <= 1e-9);
    CHECK(std::fabs(m.hd95_mm - sorted[rank - 1]) <= 1e-9);
    // border_mask agrees with the brute-force border
    std::vector<uint8_t> bm(n, 7);
    const std::size_t nb = ffseg_tools::border_mask(a.data(), d, bm.data());
    CHECK(bm == brute_border(a, d));
    CHECK(nb == m.border_a);
  }
}

TEST_CASE("metrics: deepest voxel of a box") {
  const int d[3] = {16, 16, 16};
  const auto m = box(d, 3, 9, 2, 6, 4, 12);  // 7 x 5 x 9 voxels
  std::array<int, 3> ijk{};
  double dist = 0;
  const double s1[3] = {1, 1, 1};
  REQUIRE(ffseg_tools::find_deepest_voxel(m.data(), d, s1, &ijk, &dist));
  // depth 3 (limited by the 5-voxel j extent) for i in 5..7, j = 4, k in 6..10;
  // the lowest linear index wins
  CHECK(ijk == std::array<int, 3>{5, 4, 6});
  CHECK(dist == doctest::Approx(3.0));
  // anisotropic: the j extent (0.5 mm voxels) still limits, depth 3 * 0.5
  const double s2[3] = {1, 0.5, 2};
  REQUIRE(ffseg_tools::find_deepest_voxel(m.data(), d, s2, &ijk, &dist));
  CHECK(ijk == std::array<int, 3>{4, 4, 4});
  CHECK(dist == doctest::Approx(1.5));
  // odd box 5^3 filling the whole grid: beyond the grid is background
  const int d5[3] = {5, 5, 5};
  const std::vector<uint8_t> full(125, 1);
  REQUIRE(ffseg_tools::find_deepest_voxel(full.data(), d5, s1, &ijk, &dist));
  CHECK(ijk == std::array<int, 3>{2, 2, 2});
  CHECK(dist == doctest::Approx(3.0));
  // matches the maximum of edt_mm(target_nonzero = false) inside the grid
  const double s3[3] = {0.9, 1.7, 0.6};
  const auto bl = ball(d, 7.3, 8.1, 6.6, 5.5);
  REQUIRE(ffseg_tools::find_deepest_voxel(bl.data(), d, s3, &ijk, &dist));
  const auto e = ffseg_tools::edt_mm(bl.data(), d, s3, false);
  const std::size_t best = std::size_t(std::max_element(e.begin(), e.end()) - e.begin());
  CHECK(lin(d, ijk[0], ijk[1], ijk[2]) == best);
  CHECK(dist == doctest::Approx(e[best]).epsilon(1e-12));
}
