// Fast marching (image/fast_marching): accuracy of the first-order scheme, real
// spacing, barriers, competing fronts (eq. 6.2.5), the time cap, the voxel bound
// and the exact workspace size.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "arena.h"
#include "fast_marching.h"
#include "test_util.h"

namespace {

using ffseg::FastMarching;
using ffseg::FmStatus;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Marcher {
  FastMarching fm;
  ffseg_test::ArenaBox box;
  Marcher(int64_t max_voxels, bool labels)
      : box([&](ffseg::Arena& a) { fm.carve(a, max_voxels, labels); }) {}
};

int64_t lin(const int64_t n[3], int64_t i, int64_t j, int64_t k) { return i + n[0] * (j + n[1] * k); }

// The same upwind update, written independently of the class: per axis the
// smaller accepted neighbour, axes added in increasing value while the root
// exceeds the next one.
float ref_solve(const std::vector<float>& t, const std::vector<char>& acc, const int64_t n[3],
                const double h[3], int64_t i, int64_t j, int64_t k, float s) {
  if (!(s > 0)) return kInf;
  std::vector<std::pair<double, double>> up;  // (t_a, 1/h_a^2)
  for (int a = 0; a < 3; ++a) {
    float best = kInf;
    for (int d = -1; d <= 1; d += 2) {
      int64_t q[3] = {i, j, k};
      q[a] += d;
      if (q[a] < 0 || q[a] >= n[a]) continue;
      const int64_t u = lin(n, q[0], q[1], q[2]);
      if (acc[u] && t[u] < best) best = t[u];
    }
    if (best < kInf) up.push_back({double(best), 1.0 / (h[a] * h[a])});
  }
  std::stable_sort(up.begin(), up.end(), [](auto& x, auto& y) { return x.first < y.first; });
  double A = 0, B = 0, C = -1.0 / (double(s) * double(s)), sol = INFINITY;
  for (auto& e : up) {
    if (sol < e.first) break;
    A += e.second;
    B += e.second * e.first;
    C += e.second * e.first * e.first;
    const double disc = B * B - A * C;
    if (disc < 0) break;
    sol = (B + std::sqrt(disc)) / A;
  }
  return float(sol);
}

// Reference march: the trial voxel of least time found by a linear scan.
std::vector<float> ref_march(const int64_t n[3], const double h[3], const std::vector<float>& speed,
                             const std::vector<int64_t>& seeds) {
  const int64_t N = n[0] * n[1] * n[2];
  std::vector<float> t(size_t(N), kInf);
  std::vector<char> acc(size_t(N), 0), trial(size_t(N), 0);
  for (int64_t s : seeds) { t[s] = 0; trial[s] = 1; }
  for (;;) {
    int64_t m = -1;
    for (int64_t v = 0; v < N; ++v)
      if (trial[v] && (m < 0 || t[v] < t[m])) m = v;
    if (m < 0) break;
    trial[m] = 0;
    acc[m] = 1;
    const int64_t k = m / (n[0] * n[1]), j = (m / n[0]) % n[1], i = m % n[0];
    for (int a = 0; a < 3; ++a)
      for (int d = -1; d <= 1; d += 2) {
        int64_t q[3] = {i, j, k};
        q[a] += d;
        if (q[a] < 0 || q[a] >= n[a]) continue;
        const int64_t u = lin(n, q[0], q[1], q[2]);
        if (acc[u]) continue;
        const float tu = ref_solve(t, acc, n, h, q[0], q[1], q[2], speed[u]);
        if (tu < t[u]) { t[u] = tu; trial[u] = 1; }
      }
  }
  return t;
}

}  // namespace

TEST_CASE("fast marching: point source at unit speed gives the distance, within first-order bounds") {
  const int64_t n[3] = {61, 61, 61};
  const double h[3] = {1, 1, 1};
  Marcher M(n[0] * n[1] * n[2], false);
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  std::fill(M.fm.speed_buffer(), M.fm.speed_buffer() + M.fm.voxel_count(), 1.0f);
  const int64_t c = 30;
  REQUIRE(M.fm.seed(c, c, c) == FmStatus::ok);
  REQUIRE(M.fm.march(M.fm.speed_buffer(), kInf) == FmStatus::ok);
  CHECK(M.fm.accepted() == M.fm.voxel_count());
  const float* T = M.fm.times();
  // Along the axes the update is one-dimensional: T = r exactly.
  for (int64_t r = 0; r <= 30; ++r) {
    CHECK(T[lin(n, c + r, c, c)] == float(r));
    CHECK(T[lin(n, c, c - r, c)] == float(r));
    CHECK(T[lin(n, c, c, c + r)] == float(r));
  }
  // Everywhere: never below the distance (the scheme overestimates), and above
  // it by at most the first-order error: T - r <= 0.35 + 0.42 ln(1 + r) voxels
  // (measured 0.55 at r in [1, 2), 1.22 in [10, 11), 1.71 in [29, 30)). The
  // source's singularity is not resolved, so the absolute error grows like
  // log r while the relative error falls.
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        const double r = std::sqrt(double((i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c)));
        const double e = double(T[lin(n, i, j, k)]) - r;
        CHECK(e >= -1e-5 * (1 + r));
        CHECK(e <= 0.35 + 0.42 * std::log(1 + r));
      }
  for (int64_t d = 1; d <= 30; ++d) {
    const double r = std::sqrt(3.0) * double(d);
    const double rel = (double(T[lin(n, c + d, c + d, c + d)]) - r) / r;
    // The relative error on the diagonal falls with distance: measured 31.9% at
    // d = 1, 13.2% at d = 10, 6.3% at d = 15.
    CHECK(rel > 0);
    CHECK(rel < (d < 10 ? 0.33 : d < 15 ? 0.135 : 0.065));
  }
}

TEST_CASE("fast marching: anisotropic spacing 0.7 x 0.9 x 2.5 mm gives times in mm") {
  const int64_t n[3] = {41, 33, 13};
  const double h[3] = {0.7, 0.9, 2.5};
  Marcher M(n[0] * n[1] * n[2], false);
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  std::fill(M.fm.speed_buffer(), M.fm.speed_buffer() + M.fm.voxel_count(), 1.0f);
  const int64_t ci = 20, cj = 16, ck = 6;
  REQUIRE(M.fm.seed(ci, cj, ck) == FmStatus::ok);
  REQUIRE(M.fm.march(M.fm.speed_buffer(), kInf) == FmStatus::ok);
  const float* T = M.fm.times();
  for (int64_t r = 1; r <= 6; ++r) {
    CHECK(T[lin(n, ci + r, cj, ck)] == doctest::Approx(0.7 * double(r)).epsilon(1e-6));
    CHECK(T[lin(n, ci, cj - r, ck)] == doctest::Approx(0.9 * double(r)).epsilon(1e-6));
    CHECK(T[lin(n, ci, cj, ck + r)] == doctest::Approx(2.5 * double(r)).epsilon(1e-6));
  }
  // Off the axes: at least the distance in mm, at most the first-order excess in
  // units of the largest spacing.
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        const double dx = 0.7 * double(i - ci), dy = 0.9 * double(j - cj), dz = 2.5 * double(k - ck);
        const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
        const double e = double(T[lin(n, i, j, k)]) - r;
        CHECK(e >= -1e-5 * (1 + r));
        CHECK(e <= 2.5 * (0.35 + 0.42 * std::log(1 + r / 0.7)));
      }
  // Voxel units would give 6 for six slices; millimetres give 15.
  CHECK(T[lin(n, ci, cj, ck + 6)] == doctest::Approx(15.0));
}

TEST_CASE("fast marching: a zero-speed wall is not crossed, a tiny-speed one only at its cost") {
  const int64_t n[3] = {30, 24, 20};
  const double h[3] = {1, 1, 1};
  Marcher M(n[0] * n[1] * n[2], false);
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  float* S = M.fm.speed_buffer();
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) S[lin(n, i, j, k)] = (i == 15) ? 0.0f : 1.0f;
  REQUIRE(M.fm.seed(5, 12, 10) == FmStatus::ok);
  REQUIRE(M.fm.march(S, kInf) == FmStatus::ok);
  int64_t behind_reached = 0, before_unreached = 0;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        const int64_t v = lin(n, i, j, k);
        if (i >= 15) {
          behind_reached += M.fm.states()[v] == FastMarching::kAccepted;
          CHECK(M.fm.times()[v] == kInf);
        } else {
          before_unreached += M.fm.states()[v] != FastMarching::kAccepted;
        }
      }
  CHECK(behind_reached == 0);
  CHECK(before_unreached == 0);
  CHECK(M.fm.accepted() == 15 * n[1] * n[2]);

  // A wall of speed 1e-3: crossing one voxel costs 1000 mm of travel.
  M.fm.clear_front();
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j) S[lin(n, 15, j, k)] = 1e-3f;
  REQUIRE(M.fm.seed(5, 12, 10) == FmStatus::ok);
  REQUIRE(M.fm.march(S, 500.0f) == FmStatus::ok);
  CHECK(M.fm.accepted() == 15 * n[1] * n[2]);  // the cap stops the march at the wall
  M.fm.clear_front();
  REQUIRE(M.fm.seed(5, 12, 10) == FmStatus::ok);
  REQUIRE(M.fm.march(S, kInf) == FmStatus::ok);
  CHECK(M.fm.accepted() == M.fm.voxel_count());
  CHECK(M.fm.times()[lin(n, 16, 12, 10)] > 1000.0f);
  CHECK(M.fm.times()[lin(n, 16, 12, 10)] < 1012.0f);
}

TEST_CASE("fast marching: two fronts split a uniform box at the bisector (eq. 6.2.5)") {
  const int64_t n[3] = {40, 20, 18};
  const double h[3] = {1, 1, 1};
  Marcher M(n[0] * n[1] * n[2], true);
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  std::fill(M.fm.speed_buffer(), M.fm.speed_buffer() + M.fm.voxel_count(), 1.0f);
  // Point fronts at i = 5 and i = 34: the bisector is the plane i = 19.5.
  const int64_t seeds[2] = {5, 34};
  for (uint16_t f = 0; f < 2; ++f) {
    M.fm.clear_front();
    REQUIRE(M.fm.seed(seeds[f], 10, 9) == FmStatus::ok);
    REQUIRE(M.fm.march(M.fm.speed_buffer(), kInf) == FmStatus::ok);
    REQUIRE(M.fm.merge_labels(f) == FmStatus::ok);
  }
  int64_t wrong = 0;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) wrong += M.fm.labels()[lin(n, i, j, k)] != (i <= 19 ? 0 : 1);
  CHECK(wrong == 0);

  // Per-front speeds: plane fronts at i = 0 (speed 1) and i = 39 (speed 2)
  // meet where i = (39 - i) / 2, i = 13; the tie there goes to front 0.
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  std::vector<float> fast(size_t(M.fm.voxel_count()), 2.0f);
  for (uint16_t f = 0; f < 2; ++f) {
    M.fm.clear_front();
    for (int64_t k = 0; k < n[2]; ++k)
      for (int64_t j = 0; j < n[1]; ++j) REQUIRE(M.fm.seed(f == 0 ? 0 : 39, j, k) == FmStatus::ok);
    REQUIRE(M.fm.march(f == 0 ? M.fm.speed_buffer() : fast.data(), kInf) == FmStatus::ok);
    REQUIRE(M.fm.merge_labels(f) == FmStatus::ok);
  }
  wrong = 0;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        const int64_t v = lin(n, i, j, k);
        wrong += M.fm.labels()[v] != (i <= 13 ? 0 : 1);
        wrong += M.fm.best_times()[v] != (i <= 13 ? float(i) : float(39 - i) * 0.5f);
      }
  CHECK(wrong == 0);
}

TEST_CASE("fast marching: the time cap leaves far voxels unreached, the near ones exact") {
  const int64_t n[3] = {41, 41, 41};
  const double h[3] = {1, 1, 1};
  Marcher M(n[0] * n[1] * n[2], false);
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  std::fill(M.fm.speed_buffer(), M.fm.speed_buffer() + M.fm.voxel_count(), 1.0f);
  REQUIRE(M.fm.seed(20, 20, 20) == FmStatus::ok);
  REQUIRE(M.fm.march(M.fm.speed_buffer(), kInf) == FmStatus::ok);
  const std::vector<float> full(M.fm.times(), M.fm.times() + M.fm.voxel_count());
  M.fm.clear_front();
  REQUIRE(M.fm.seed(20, 20, 20) == FmStatus::ok);
  const float cap = 10.0f;
  REQUIRE(M.fm.march(M.fm.speed_buffer(), cap) == FmStatus::ok);
  int64_t expect = 0, mismatched = 0, far_reached = 0;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        const int64_t v = lin(n, i, j, k);
        const bool in = full[v] <= cap;
        expect += in;
        const bool acc = M.fm.states()[v] == FastMarching::kAccepted;
        mismatched += acc != in;
        if (acc && M.fm.times()[v] != full[v]) ++mismatched;
        if (!acc && M.fm.times()[v] != kInf) ++mismatched;
        const double r = std::sqrt(double((i - 20) * (i - 20) + (j - 20) * (j - 20) + (k - 20) * (k - 20)));
        if (r > 10.001) far_reached += acc;
      }
  CHECK(M.fm.accepted() == expect);
  CHECK(mismatched == 0);
  CHECK(far_reached == 0);
  CHECK(expect > 3000);  // about a ball of radius 9.3 (4/3 pi 10^3 = 4189 minus the overestimate)
  CHECK(expect < int64_t(M.fm.voxel_count()));
}

TEST_CASE("fast marching: a random speed and spacing match a plain reference march") {
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> U(0.05f, 1.0f);
  const int64_t n[3] = {19, 14, 11};
  const double h[3] = {0.83, 1.1, 1.9};
  Marcher M(n[0] * n[1] * n[2], false);
  REQUIRE(M.fm.begin(n, h) == FmStatus::ok);
  std::vector<float> speed(size_t(M.fm.voxel_count()));
  for (float& s : speed) s = U(rng);
  for (int64_t v = 0; v < M.fm.voxel_count(); v += 97) speed[size_t(v)] = 0.0f;  // holes
  const std::vector<int64_t> seeds = {lin(n, 3, 4, 5), lin(n, 15, 10, 2), lin(n, 9, 0, 10)};
  for (int64_t s : seeds) REQUIRE(M.fm.seed(s) == FmStatus::ok);
  REQUIRE(M.fm.march(speed.data(), kInf) == FmStatus::ok);
  const std::vector<float> ref = ref_march(n, h, speed, seeds);
  int64_t differ = 0, reached = 0;
  for (int64_t v = 0; v < M.fm.voxel_count(); ++v) {
    reached += ref[v] < kInf;
    if (!(ref[v] == M.fm.times()[v])) ++differ;
  }
  CHECK(differ == 0);  // same scheme, same float rounding: bit-identical
  CHECK(reached == M.fm.accepted());
  CHECK(reached > M.fm.voxel_count() * 9 / 10);
}

TEST_CASE("fast marching: a crop over the bound is refused, naming its size") {
  Marcher M(1000, false);
  const double h[3] = {1, 1, 1};
  const int64_t fits[3] = {10, 10, 10};
  char msg[256] = "";
  CHECK(M.fm.begin(fits, h, msg, sizeof msg) == FmStatus::ok);
  const int64_t big[3] = {11, 10, 10};
  CHECK(M.fm.begin(big, h, msg, sizeof msg) == FmStatus::too_large);
  CHECK(std::string(msg).find("1100 voxels") != std::string::npos);
  CHECK(std::string(msg).find("1000") != std::string::npos);
  CHECK(M.fm.seed(0) == FmStatus::not_carved);  // a refused crop leaves nothing to march
  const int64_t huge[3] = {int64_t(1) << 40, int64_t(1) << 40, int64_t(1) << 40};  // product overflows int64
  CHECK(M.fm.begin(huge, h, msg, sizeof msg) == FmStatus::too_large);
  const int64_t zero[3] = {10, 0, 10};
  CHECK(M.fm.begin(zero, h, msg, sizeof msg) == FmStatus::bad_grid);
  const double bad_h[3] = {1, std::nan(""), 1};
  CHECK(M.fm.begin(fits, bad_h, msg, sizeof msg) == FmStatus::bad_grid);
  CHECK(M.fm.begin(fits, h) == FmStatus::ok);
  CHECK(M.fm.seed(1000) == FmStatus::bad_seed);
  CHECK(M.fm.seed(10, 0, 0) == FmStatus::bad_seed);
  CHECK(M.fm.merge_labels(0) == FmStatus::no_labels);
}

TEST_CASE("fast marching: the workspace carve is exact") {
  for (bool labels : {false, true}) {
    for (int64_t m : {int64_t(1), int64_t(1000), int64_t(1) << 20}) {
      ffseg::Arena probe;
      FastMarching fm;
      fm.carve(probe, m, labels);
      auto up = [](size_t b) { return ffseg::Arena::round_up(b); };
      // times, states, heap positions, heap entries, speed (+ running minimum, labels)
      const size_t exact = up(4 * size_t(m)) + up(size_t(m)) + up(4 * size_t(m)) + up(8 * size_t(m)) +
                           up(4 * size_t(m)) + (labels ? up(4 * size_t(m)) + up(2 * size_t(m)) : 0);
      CHECK(probe.used() == exact);
      // The real pass over exactly that many bytes uses exactly that many.
      std::vector<unsigned char> mem(probe.used() + 64);
      void* base = reinterpret_cast<void*>((reinterpret_cast<uintptr_t>(mem.data()) + 63) & ~uintptr_t(63));
      ffseg::Arena real(base, probe.used());
      fm.carve(real, m, labels);
      CHECK(real.ok());
      CHECK(real.used() == probe.used());
      CHECK(fm.max_voxels() == m);
      // One byte short: nothing is usable.
      ffseg::Arena short_a(base, probe.used() - 1);
      fm.carve(short_a, m, labels);
      CHECK(!short_a.ok());
      const int64_t one[3] = {1, 1, 1};
      const double h[3] = {1, 1, 1};
      CHECK(fm.begin(one, h) == FmStatus::not_carved);
    }
  }
}

TEST_CASE("fast marching: seeding a whole mask gives the times of seeding it voxel by voxel, bit for bit") {
  // A blob of seeds (an ellipsoid plus a one-voxel spur and a lone voxel),
  // random speeds: seed_mask() accepts the blob's interior at once and
  // pushes only its surface, seed() pushes every voxel.
  const int64_t n[3] = {23, 19, 17};
  const double h[3] = {0.8, 1.1, 1.7};
  const int64_t count = n[0] * n[1] * n[2];
  std::vector<uint8_t> mask(size_t(count), 0);
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) {
        const double x = (i - 9.3) / 6.0, y = (j - 8.1) / 5.0, z = (k - 7.7) / 3.5;
        if (x * x + y * y + z * z <= 1.0) mask[size_t(lin(n, i, j, k))] = 1;
      }
  for (int64_t i = 15; i < 18; ++i) mask[size_t(lin(n, i, 8, 8))] = 1;
  mask[size_t(lin(n, 20, 2, 14))] = 1;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> U(0.05f, 1.0f);
  std::vector<float> speed(static_cast<size_t>(count));
  for (float& s : speed) s = U(rng);
  Marcher a(count, false), b(count, false);
  for (float cap : {4.0f, kInf}) {
    CAPTURE(cap);
    REQUIRE(a.fm.begin(n, h) == FmStatus::ok);
    REQUIRE(b.fm.begin(n, h) == FmStatus::ok);
    REQUIRE(a.fm.seed_mask(mask.data()) == FmStatus::ok);
    for (int64_t v = 0; v < count; ++v)
      if (mask[size_t(v)]) REQUIRE(b.fm.seed(v) == FmStatus::ok);
    REQUIRE(a.fm.march(speed.data(), cap) == FmStatus::ok);
    REQUIRE(b.fm.march(speed.data(), cap) == FmStatus::ok);
    CHECK(a.fm.accepted() == b.fm.accepted());
    CHECK(std::memcmp(a.fm.times(), b.fm.times(), size_t(count) * sizeof(float)) == 0);
    if (cap < kInf) CHECK(a.fm.accepted() < count);
  }
}
