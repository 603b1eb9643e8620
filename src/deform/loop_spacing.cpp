#include "loop_spacing.h"

#include <cmath>

namespace ffseg {

void respace_loops(const CubeSphere& m, double* x, double fraction, double* scratch) {
  const uint32_t L = m.loop_len;
  const size_t nv = m.nv;
  if (L < 3 || !(fraction > 0)) return;
  double* cum = scratch;           // L + 1 arc lengths at the polyline's vertices
  double* poly = cum + (L + 1);    // L + 1 points, the first repeated at the end
  double* out = poly + 3 * (size_t(L) + 1);  // L new points
  for (uint32_t l = 0; l < m.nloops; ++l) {
    const uint32_t* lp = m.loops + size_t(l) * L;
    for (uint32_t q = 0; q <= L; ++q)
      for (int a = 0; a < 3; ++a) poly[3 * size_t(q) + a] = x[a * nv + lp[q % L]];
    cum[0] = 0;
    for (uint32_t q = 0; q < L; ++q) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = poly[3 * size_t(q + 1) + a] - poly[3 * size_t(q) + a];
        d2 += d * d;
      }
      cum[q + 1] = cum[q] + std::sqrt(d2);
    }
    const double T = cum[L];
    if (!(T > 0) || !std::isfinite(T)) continue;
    const double h = T / L;
    double off = 0;
    for (uint32_t q = 0; q < L; ++q) off += cum[q] - q * h;
    off /= L;
    // The blend's arc lengths increase with q; they wrap past T at most once
    // at either end, so the segment pointer restarts only there.
    uint32_t k = 0;
    double prev = -1;
    for (uint32_t q = 0; q < L; ++q) {
      double t = cum[q] + fraction * (off + q * h - cum[q]);
      t = std::fmod(t, T);
      if (t < 0) t += T;
      if (t < prev) k = 0;
      prev = t;
      while (k + 1 < L && cum[k + 1] <= t) ++k;
      const double seg = cum[k + 1] - cum[k];
      const double f = seg > 0 ? (t - cum[k]) / seg : 0.0;
      for (int a = 0; a < 3; ++a)
        out[3 * size_t(q) + a] = poly[3 * size_t(k) + a] + f * (poly[3 * size_t(k + 1) + a] - poly[3 * size_t(k) + a]);
    }
    for (uint32_t q = 0; q < L; ++q)
      for (int a = 0; a < 3; ++a) x[a * nv + lp[q]] = out[3 * size_t(q) + a];
  }
}

}  // namespace ffseg
