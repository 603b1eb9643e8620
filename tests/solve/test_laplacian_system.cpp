// The Laplacian system's right-hand side and positional terms
// (src/solve/laplacian_system.h, thesis 4.2.5 and eq. 4.2.6): laplacian_rhs
// against the gradient of the energy written out term by term on a small
// cube-sphere, and positional_terms' weights, floor, anchor and blend.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "laplacian_system.h"
#include "support/sphere_box.h"

using ffseg_test::SphereBox;

namespace {

// The energy of laplacian_system.h, written out directly from its definition:
//   E(y) = lambda_L sum_v |(A y)_v - (A x)_v|^2 + sum_{w_v > 0} w_v |y_v - p_v|^2
//        + lambda_u sum_loops sum_edges |(y_i - y_j) - min(1, l_mean / l_ij)(x_i - x_j)|^2
// with (A y)_v = y_v - 1/4 sum of the four neighbours, l_mean = the loop's
// length through p over its vertex count, l_ij = |x_i - x_j|.
double energy(const ffseg::CubeSphere& m, double lambda_l, double lambda_u, const std::vector<double>& x,
              const std::vector<double>& p, const std::vector<double>& w, const std::vector<double>& y) {
  double e = 0;
  for (uint32_t v = 0; v < m.nv; ++v)
    for (int c = 0; c < 3; ++c) {
      double ay = y[3 * v + c], ax = x[3 * v + c];
      for (int k = 0; k < 4; ++k) {
        ay -= 0.25 * y[3 * m.nbr[4 * v + k] + c];
        ax -= 0.25 * x[3 * m.nbr[4 * v + k] + c];
      }
      e += lambda_l * (ay - ax) * (ay - ax);
      if (w[v] > 0) e += w[v] * (y[3 * v + c] - p[3 * v + c]) * (y[3 * v + c] - p[3 * v + c]);
    }
  for (uint32_t l = 0; l < m.nloops; ++l) {
    double len = 0;
    for (uint32_t q = 0; q < m.loop_len; ++q) {
      const uint32_t i = m.loops[l * m.loop_len + q], j = m.loops[l * m.loop_len + (q + 1) % m.loop_len];
      len += std::sqrt(std::pow(p[3 * i] - p[3 * j], 2) + std::pow(p[3 * i + 1] - p[3 * j + 1], 2) +
                       std::pow(p[3 * i + 2] - p[3 * j + 2], 2));
    }
    const double lmean = len / m.loop_len;
    for (uint32_t q = 0; q < m.loop_len; ++q) {
      const uint32_t i = m.loops[l * m.loop_len + q], j = m.loops[l * m.loop_len + (q + 1) % m.loop_len];
      const double lij = std::sqrt(std::pow(x[3 * i] - x[3 * j], 2) + std::pow(x[3 * i + 1] - x[3 * j + 1], 2) +
                                   std::pow(x[3 * i + 2] - x[3 * j + 2], 2));
      const double r = std::fmin(1.0, lmean / lij);
      for (int c = 0; c < 3; ++c) {
        const double t = (y[3 * i + c] - y[3 * j + c]) - r * (x[3 * i + c] - x[3 * j + c]);
        e += lambda_u * t * t;
      }
    }
  }
  return e;
}

}  // namespace

TEST_CASE("laplacian_rhs: the normal equations' right-hand side, -1/2 the energy's gradient at 0") {
  // E is quadratic, E(y) = y^T M y - 2 b^T y + const, so b = -1/2 grad E(0),
  // and a central difference of a quadratic is its exact derivative.
  for (uint32_t n : {2u, 3u}) {
    SphereBox b(n);
    const uint32_t nv = b.m.nv;
    std::mt19937_64 rng(n);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    // A lumpy sphere, targets about 20 % farther out (loops through the
    // targets are longer: min(1, .) caps some edges, not others), some
    // vertices without a target.
    std::vector<double> x = b.sphere(10), p(size_t(3) * nv), w(nv);
    for (auto& q : x) q += 0.8 * U(rng);
    for (uint32_t v = 0; v < nv; ++v) {
      for (int c = 0; c < 3; ++c) p[3 * v + c] = 1.2 * x[3 * v + c] + 0.5 * U(rng);
      w[v] = v % 5 == 0 ? 0.0 : 0.5 + 0.5 * U(rng) + 0.5;
    }
    for (double lambda_u : {0.0, 0.7}) {
      CAPTURE(n);
      CAPTURE(lambda_u);
      const double lambda_l = 1.3;
      std::vector<double> rhs(size_t(3) * nv), lap(size_t(3) * nv);
      ffseg::laplacian_rhs(b.m, lambda_l, lambda_u, x.data(), p.data(), w.data(), rhs.data(), lap.data());
      const double e0 = energy(b.m, lambda_l, lambda_u, x, p, w, std::vector<double>(size_t(3) * nv, 0.0));
      double scale = 0;
      for (double q : rhs) scale = std::fmax(scale, std::fabs(q));
      REQUIRE(scale > 1);
      for (uint32_t v = 0; v < nv; ++v)
        for (int c = 0; c < 3; ++c) {
          std::vector<double> y(size_t(3) * nv, 0.0);
          y[3 * v + c] = 1.0;
          const double ep = energy(b.m, lambda_l, lambda_u, x, p, w, y);
          y[3 * v + c] = -1.0;
          const double em = energy(b.m, lambda_l, lambda_u, x, p, w, y);
          const double grad = (ep - em) / 2;
          CAPTURE(v);
          CAPTURE(c);
          CHECK(std::fabs(rhs[size_t(c) * nv + v] - (-0.5 * grad)) <= 1e-9 * (e0 + scale));
        }
    }
  }
}

TEST_CASE("laplacian_rhs: targets at the positions, no loop term: the positions solve the system") {
  // With p = x and lambda_u = 0, b = (lambda_L A^T A + W) x: the matrix that
  // assemble_laplacian() builds, applied to x by hand.
  SphereBox b(3);
  const uint32_t nv = b.m.nv;
  std::vector<double> x = b.sphere(7), w(nv);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (auto& q : x) q += U(rng);
  for (uint32_t v = 0; v < nv; ++v) w[v] = U(rng);
  std::vector<double> rhs(size_t(3) * nv), lap(size_t(3) * nv);
  const double lambda_l = 2.0;
  ffseg::laplacian_rhs(b.m, lambda_l, 0.0, x.data(), x.data(), w.data(), rhs.data(), lap.data());
  for (uint32_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) {
      // (A^T A x)_v = (A x)_v - 1/4 sum_k (A x)_{nbr k}
      auto ax = [&](uint32_t u) {
        double s = x[3 * u + c];
        for (int k = 0; k < 4; ++k) s -= 0.25 * x[3 * b.m.nbr[4 * u + k] + c];
        return s;
      };
      double ata = ax(v);
      for (int k = 0; k < 4; ++k) ata -= 0.25 * ax(b.m.nbr[4 * v + k]);
      CHECK(rhs[size_t(c) * nv + v] == doctest::Approx(lambda_l * ata + w[v] * x[3 * v + c]).epsilon(1e-12));
    }
}

TEST_CASE("positional_terms: eq. 4.2.6 weights by |d| / mean, the floor, the anchor and the blended target") {
  // Five vertices: displacements of length 1, 2, 3 and 0.1 (has), one without.
  const uint32_t nv = 5;
  const double x[15] = {0, 0, 0, 1, 1, 1, -2, 0, 3, 4, 4, 4, 9, 9, 9};
  const double d[15] = {1, 0, 0, 0, 2, 0, 0, 0, -3, 0.1, 0, 0, 5, 5, 5};
  const uint8_t has[5] = {1, 1, 1, 1, 0};
  const double alpha = 0.5, lambda_p = 2.0;
  double target[15], w[5], scratch[5];
  ffseg::positional_terms(nv, x, d, has, alpha, lambda_p, target, w, scratch);
  // |alpha d| = 0.5, 1, 1.5, 0.05; mean 3.05 / 4.
  const double mean = (0.5 + 1 + 1.5 + 0.05) / 4;
  const double anchor = lambda_p * 1e-3;
  const double rel[4] = {0.5 / mean, 1 / mean, 1.5 / mean, 0.25 /* floor: 0.05 / mean = 0.066 */};
  for (uint32_t v = 0; v < 4; ++v) {
    CAPTURE(v);
    const double wp = lambda_p * rel[v];
    CHECK(w[v] == doctest::Approx(anchor + wp).epsilon(1e-14));
    for (int a = 0; a < 3; ++a) {
      const double p = x[3 * v + a] + alpha * d[3 * v + a];
      CHECK(target[3 * v + a] == doctest::Approx((anchor * x[3 * v + a] + wp * p) / (anchor + wp)).epsilon(1e-14));
    }
  }
  // Without a displacement: held where it is by the anchor alone.
  CHECK(w[4] == doctest::Approx(anchor).epsilon(1e-14));
  for (int a = 0; a < 3; ++a) CHECK(target[12 + a] == x[12 + a]);
  // The targets lie between u and u + alpha d, very close to the latter.
  for (int a = 0; a < 3; ++a) CHECK(std::fabs(target[3 + a] - (x[3 + a] + alpha * d[3 + a])) < 1e-3 * 2);

  // Every displacement zero: the mean is 0 and every vertex with one gets the
  // weight lambda_p (relative 1) plus the anchor, its target its position.
  const double z[15] = {0};
  ffseg::positional_terms(nv, x, z, has, alpha, lambda_p, target, w, scratch);
  for (uint32_t v = 0; v < 4; ++v) CHECK(w[v] == doctest::Approx(lambda_p + anchor).epsilon(1e-14));
  CHECK(w[4] == doctest::Approx(anchor).epsilon(1e-14));
  for (int q = 0; q < 15; ++q) CHECK(target[q] == doctest::Approx(x[q]).epsilon(1e-14));

  // No vertex has a displacement: only anchors, the system stays definite.
  const uint8_t none[5] = {0, 0, 0, 0, 0};
  ffseg::positional_terms(nv, x, d, none, alpha, lambda_p, target, w, scratch);
  for (uint32_t v = 0; v < nv; ++v) CHECK(w[v] == doctest::Approx(anchor).epsilon(1e-14));
  for (int q = 0; q < 15; ++q) CHECK(target[q] == x[q]);
}
