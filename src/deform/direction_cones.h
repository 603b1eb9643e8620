// Cones of displacement directions over the buckets of a spatial grid, for
// the fold prevention's direction rule (thesis 4.2.4, the tau test of eq.
// 4.2.1). Most pairs a ball query meets agree in direction: neighbouring
// stretches of one surface move alike. A bucket's cone (the unit mean of its
// points' directions and the least cosine of any of them to it) bounds the
// cosine between a query's direction and every member's from below, so a
// whole bucket can be known to agree without a distance or direction test
// of its points.
#pragma once
#include <cstdint>

#include "arena.h"
#include "spatial_grid.h"

namespace ffseg {

struct DirectionCones {
  // 4 per grid point, at each bucket's first slot: the axis (unit), then the
  // least cosine of a member to it (kNoMember: the bucket has none; <= 0: no
  // bound).
  double* cone = nullptr;
  void carve(Arena& a, uint32_t max_points);

  // Over the buckets of grid, built over 2 * nv points (point id and id + nv
  // belong to vertex id): the members are the vertices v with has[v] and
  // len[v] = |d_v| > 0, the only ones the direction rule may pair.
  void build(const SpatialGrid& grid, uint32_t nv, const double* d, const double* len, const uint8_t* has);

  // Whether the cosine between u (the unit direction of a displacement whose
  // length is bounded()) and the direction of every member of the bucket at
  // slot first surely exceeds tau, as dot / (|d_i| |d_j|) computes it: a
  // margin far above rounding separates the bound from tau.
  bool all_agree(uint32_t first, const double u[3], double tau) const {
    const double* c = cone + 4 * size_t(first);
    const double c2 = c[3];
    if (c2 == kNoMember) return true;
    const double c1 = u[0] * c[0] + u[1] * c[1] + u[2] * c[2];
    // cos(t1 + t2) = c1 c2 - s1 s2 for the angles t1 (u to the axis) and t2
    // (the axis to its farthest member), both below 90 degrees here, is the
    // least cosine u can make with a member; compared without square roots.
    const double p = c1 * c2 - (tau + kMargin);
    return c1 > 0 && c2 > 0 && p > 0 && p * p > (1 - c1 * c1) * (1 - c2 * c2);
  }

  // Whether a displacement of length l may be bounded at all: between these
  // the rule's own product |d_i| |d_j| neither overflows nor underflows.
  static bool bounded(double l) { return l >= 1e-100 && l <= 1e100; }

  static constexpr double kNoMember = 2.0;
  // Near a cosine of 1 its sine reacts to a rounding of 1e-16 by 1e-8: the
  // margin covers that many times over and costs nothing (tau is well below
  // the cosines of directions that agree).
  static constexpr double kMargin = 1e-6;
};

}  // namespace ffseg
