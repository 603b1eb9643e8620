#include "fold_prevention.h"

#include <cmath>

namespace ffseg {

void IntersectionScratch::carve(Arena& a, uint32_t nv) {
  grid.carve(a, 2 * nv);
  pts = a.alloc<double>(size_t(6) * nv);
  mark = a.alloc<uint8_t>(nv);
  len = a.alloc<double>(nv);
  cones.carve(a, 2 * nv);
  moved.carve(a, nv);
}

namespace {
constexpr int kMaxPasses = 8;
}

uint32_t prevent_folds(const CubeSphere& m, const double* x, double* d, const uint8_t* has, double tau,
                       double alpha, IntersectionScratch& s) {
  const uint32_t nv = m.nv;
  // Cell size: the mean edge length, or half the longest displacement if
  // larger, so that a ball query spans a handful of cells per axis.
  double edge = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    const uint32_t w = m.nbr[4 * size_t(v)];
    double e2 = 0;
    for (int a = 0; a < 3; ++a) e2 += (x[3 * size_t(v) + a] - x[3 * size_t(w) + a]) * (x[3 * size_t(v) + a] - x[3 * size_t(w) + a]);
    edge += std::sqrt(e2);
  }
  edge /= double(nv);
  // mark bits: kEver (shortened this step), kNow (shorten after this pass),
  // kActive (query this pass: everyone first, then only the vertices just
  // shortened, since a conflict always marks both of its vertices).
  constexpr uint8_t kEver = 1, kNow = 2, kActive = 4;
  for (uint32_t v = 0; v < nv; ++v) s.mark[v] = kActive;
  uint32_t shortened = 0;
  // This step moves u_i to u_i + alpha d_i: only that stretch can cross.
  double dsum = 0;
  uint32_t dn = 0, moving = 0;  // moving: vertices whose stretch has a length
  for (uint32_t v = 0; v < nv; ++v) {
    double len2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double dv = has[v] ? alpha * d[3 * size_t(v) + a] : 0.0;
      s.pts[3 * size_t(v) + a] = x[3 * size_t(v) + a];
      s.pts[3 * (size_t(nv) + v) + a] = x[3 * size_t(v) + a] + dv;
      len2 += dv * dv;
    }
    if (has[v]) {
      dsum += std::sqrt(len2);
      ++dn;
      moving += len2 > 0;
    }
    const double* dv = d + 3 * size_t(v);
    s.len[v] = std::sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
  }
  if (!(dsum > 0)) return 0;
  // One grid over all points for all passes. A pass after the first moves
  // only the targets of the vertices shortened so far (halving keeps their
  // directions, so the cones hold): their entries in the grid are stale and
  // passed over, and a small grid over the moved targets alone, rebuilt each
  // pass, answers for them. Whether a point lies within r of u_i is decided
  // by the same test of the same coordinates as a grid built afresh over all
  // points would decide it, so the conflicts are the same.
  const double h = std::fmax(edge, dsum / dn);
  s.grid.build(s.pts, 2 * nv, h);
  s.cones.build(s.grid, nv, d, s.len, has);
  const double* targets = s.pts + 3 * size_t(nv);
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    uint32_t conflicts = 0;
    for (uint32_t i = 0; i < nv; ++i) {
      if (!has[i] || !(s.mark[i] & kActive)) continue;
      const double* di = d + 3 * size_t(i);
      const double li = s.len[i];
      if (!(li > 0)) continue;
      const uint32_t* nb = m.nbr + 4 * size_t(i);
      const double* ui = x + 3 * size_t(i);
      auto conflict = [&](uint32_t id) {
        const uint32_t j = id < nv ? id : id - nv;
        if (j == i || !has[j] || j == nb[0] || j == nb[1] || j == nb[2] || j == nb[3]) return;
        const double* dj = d + 3 * size_t(j);
        const double lj = s.len[j];
        if (!(lj > 0)) return;
        const double c = (di[0] * dj[0] + di[1] * dj[1] + di[2] * dj[2]) / (li * lj);
        if (c > tau) return;
        // Only a point ahead of u_i, on a path that closes in on u_j, can be
        // crossed: vertices on opposite sides of a growing or shrinking
        // surface disagree in direction but move apart or in parallel.
        const double* uj = x + 3 * size_t(j);
        const double* q = s.pts + 3 * size_t(id);
        const double ahead = (q[0] - ui[0]) * di[0] + (q[1] - ui[1]) * di[1] + (q[2] - ui[2]) * di[2];
        const double closing = (di[0] - dj[0]) * (ui[0] - uj[0]) + (di[1] - dj[1]) * (ui[1] - uj[1]) +
                               (di[2] - dj[2]) * (ui[2] - uj[2]);
        if (ahead > 0 && closing < 0) {
          s.mark[i] |= kNow;
          s.mark[j] |= kNow;
          ++conflicts;
        }
      };
      // A bucket whose every member agrees with d_i in direction holds no
      // partner of a conflict: it is passed over as a whole. (At most seven
      // halvings keep the members' lengths within DirectionCones::bounded()'s
      // reasons.)
      const bool coned = DirectionCones::bounded(li);
      const double u[3] = {di[0] / li, di[1] / li, di[2] / li};
      auto agree = [&](uint32_t first) { return coned && s.cones.all_agree(first, u, tau); };
      const double r = alpha * li;
      if (pass == 0) {
        s.grid.for_each_in_ball_unless(ui, r, agree, conflict);
        continue;
      }
      s.grid.for_each_in_ball_unless(ui, r, agree, [&](uint32_t id) {
        if (id < nv || !(s.mark[id - nv] & kEver)) conflict(id);
      });
      s.moved.for_each_in_ball(ui, r, [&](uint32_t j) { conflict(nv + j); });
    }
    if (conflicts == 0) break;
    // Halve the conflicting displacements and move their targets (the same
    // arithmetic as the first pass's).
    uint32_t ever = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      if (s.mark[v] & kNow) {
        double was2 = 0, len2 = 0;
        for (int a = 0; a < 3; ++a) {
          const double dw = alpha * d[3 * size_t(v) + a];
          was2 += dw * dw;
          d[3 * size_t(v) + a] *= 0.5;
          const double dv = alpha * d[3 * size_t(v) + a];
          s.pts[3 * (size_t(nv) + v) + a] = x[3 * size_t(v) + a] + dv;
          len2 += dv * dv;
        }
        moving -= was2 > 0 && !(len2 > 0);
        const double* dv = d + 3 * size_t(v);
        s.len[v] = std::sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
        s.mark[v] = kEver | kActive;
      } else {
        s.mark[v] &= kEver;
      }
      ever += (s.mark[v] & kEver) != 0;
    }
    // A sum of the stretches' lengths is positive while one of them is (no
    // NaN: the first pass would have stopped).
    if (moving == 0) break;
    s.moved.size_table(ever);
    s.moved.build_if(targets, nv, h, [&](uint32_t v) { return (s.mark[v] & kEver) != 0; });
  }
  for (uint32_t v = 0; v < nv; ++v) shortened += (s.mark[v] & kEver) != 0;
  return shortened;
}

}  // namespace ffseg
