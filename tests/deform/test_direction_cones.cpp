// Cones of displacement directions (src/deform/direction_cones.h): a bucket
// the cone says agrees with a direction holds no member whose cosine with it,
// computed as the fold prevention computes it, is tau or below; buckets of
// directions that agree are recognised as such.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "direction_cones.h"
#include "test_util.h"

using ffseg_test::ArenaBox;

namespace {

struct ConeBox {
  ffseg::SpatialGrid grid;
  ffseg::DirectionCones cones;
  ArenaBox box;
  explicit ConeBox(uint32_t nv)
      : box([&](ffseg::Arena& a) {
          grid.carve(a, 2 * nv);
          cones.carve(a, 2 * nv);
        }) {
    REQUIRE(box.ok());
  }
};

double rule_cos(const double* di, double li, const double* dj, double lj) {
  return (di[0] * dj[0] + di[1] * dj[1] + di[2] * dj[2]) / (li * lj);
}

}  // namespace

TEST_CASE("direction cones: a bucket said to agree holds no member at or below tau") {
  constexpr uint32_t nv = 400;
  ConeBox c(nv);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uni(-1, 1);
  for (double spread : {0.02, 0.3, 1.5}) {
    // Points in a 4 mm box, cells of 1 mm: a few points a bucket. Directions
    // scattered around +z by spread (1.5: nearly any direction); some
    // vertices without a displacement or a zero one.
    std::vector<double> pts(6 * nv), d(3 * nv), len(nv);
    std::vector<uint8_t> has(nv);
    for (uint32_t v = 0; v < nv; ++v) {
      for (int a = 0; a < 3; ++a) {
        pts[3 * v + a] = 4 * uni(rng);
        pts[3 * (nv + v) + a] = 4 * uni(rng);
      }
      const double s = std::exp(3 * uni(rng));
      d[3 * v] = s * spread * uni(rng);
      d[3 * v + 1] = s * spread * uni(rng);
      d[3 * v + 2] = s;
      has[v] = v % 7 != 0;
      if (v % 11 == 0) d[3 * v] = d[3 * v + 1] = d[3 * v + 2] = 0;
      len[v] = std::sqrt(d[3 * v] * d[3 * v] + d[3 * v + 1] * d[3 * v + 1] + d[3 * v + 2] * d[3 * v + 2]);
    }
    c.grid.build(pts.data(), 2 * nv, 1.0);
    c.cones.build(c.grid, nv, d.data(), len.data(), has.data());
    uint32_t agreed = 0, buckets = 0;
    for (double tau : {-0.5, 0.0, 0.2, 0.9}) {
      for (uint32_t i = 0; i < nv; ++i) {
        if (!has[i] || !(len[i] > 0)) continue;
        const double* di = d.data() + 3 * i;
        const double u[3] = {di[0] / len[i], di[1] / len[i], di[2] / len[i]};
        c.grid.for_each_bucket([&](uint32_t first, uint32_t end) {
          ++buckets;
          if (!c.cones.all_agree(first, u, tau)) return;
          ++agreed;
          for (uint32_t k = first; k < end; ++k) {
            const uint32_t id = c.grid.id_at(k);
            const uint32_t j = id < nv ? id : id - nv;
            if (!has[j] || !(len[j] > 0)) continue;
            CHECK(rule_cos(di, len[i], d.data() + 3 * j, len[j]) > tau);
          }
        });
      }
    }
    // Narrow spreads agree almost everywhere; the widest rarely.
    MESSAGE("spread " << spread << ": " << agreed << " of " << buckets << " buckets agree");
    if (spread < 0.1) CHECK(agreed > buckets * 9 / 10);
  }
}
