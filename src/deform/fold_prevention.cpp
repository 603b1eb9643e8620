#include "fold_prevention.h"

#include <cmath>

namespace ffseg {

void IntersectionScratch::carve(Arena& a, uint32_t nv) {
  grid.carve(a, 2 * nv);
  pts = a.alloc<double>(size_t(6) * nv);
  mark = a.alloc<uint8_t>(nv);
  len = a.alloc<double>(nv);
  cones.carve(a, 2 * nv);
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
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    // This step moves u_i to u_i + alpha d_i: only that stretch can cross.
    double dsum = 0;
    uint32_t dn = 0;
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
      }
      const double* dv = d + 3 * size_t(v);
      s.len[v] = std::sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
    }
    if (!(dsum > 0)) break;
    const double h = std::fmax(edge, dsum / dn);
    s.grid.build(s.pts, 2 * nv, h);
    s.cones.build(s.grid, nv, d, s.len, has);
    uint32_t conflicts = 0;
    for (uint32_t i = 0; i < nv; ++i) {
      if (!has[i] || !(s.mark[i] & kActive)) continue;
      const double* di = d + 3 * size_t(i);
      const double li = s.len[i];
      if (!(li > 0)) continue;
      const uint32_t* nb = m.nbr + 4 * size_t(i);
      // A bucket whose every member agrees with d_i in direction holds no
      // partner of a conflict: it is passed over as a whole.
      const bool coned = DirectionCones::bounded(li);
      const double u[3] = {di[0] / li, di[1] / li, di[2] / li};
      auto agree = [&](uint32_t first) { return coned && s.cones.all_agree(first, u, tau); };
      s.grid.for_each_in_ball_unless(x + 3 * size_t(i), alpha * li, agree, [&](uint32_t id) {
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
        const double* ui = x + 3 * size_t(i);
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
      });
    }
    if (conflicts == 0) break;
    for (uint32_t v = 0; v < nv; ++v) {
      if (s.mark[v] & kNow) {
        for (int a = 0; a < 3; ++a) d[3 * size_t(v) + a] *= 0.5;
        s.mark[v] = kEver | kActive;
      } else {
        s.mark[v] &= kEver;
      }
    }
  }
  for (uint32_t v = 0; v < nv; ++v) shortened += (s.mark[v] & kEver) != 0;
  return shortened;
}

}  // namespace ffseg
