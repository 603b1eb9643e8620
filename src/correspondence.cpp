#include "correspondence.h"

#include <cmath>

namespace ffseg {

double indicator_linear(const VolumeView& vol, const double p[3]) {
  const int64_t* D = vol.dims();
  int64_t q[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    if (!(p[a] > -1.0 && p[a] < double(D[a]))) return 0.0;
    const double fl = std::floor(p[a]);
    q[a] = int64_t(fl);
    f[a] = p[a] - fl;
  }
  double acc = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
    if (w == 0) continue;
    if (vol.at_or(q[0] + dx, q[1] + dy, q[2] + dz, 0.0) != 0.0) acc += w;
  }
  return acc;
}

uint32_t search_binary(const VolumeView& vol, uint32_t nv, const double* x, const double* normals,
                       const SearchSettings& s, double* target, uint8_t* has) {
  uint32_t found = 0;
  const int steps = int(std::ceil(s.range_mm / s.step_mm));
  for (uint32_t v = 0; v < nv; ++v) {
    has[v] = 0;
    const double* u = x + 3 * size_t(v);
    double p0[3], dir[3];
    vol.world_to_index(u, p0);
    vol.world_dir_to_index(normals + 3 * size_t(v), dir);
    const bool inside = indicator_linear(vol, p0) >= 0.5;
    // Inside: look outward for the exit; outside: look inward for the entry.
    const double sgn = inside ? 1.0 : -1.0;
    double t_prev = 0;
    for (int i = 1; i <= steps; ++i) {
      double t = i * s.step_mm;
      if (t > s.range_mm) t = s.range_mm;
      double p[3];
      for (int a = 0; a < 3; ++a) p[a] = p0[a] + sgn * t * dir[a];
      const bool in = indicator_linear(vol, p) >= 0.5;
      if (in != inside) {
        // Bisection on the bracket [t_prev, t] for the 0.5 level.
        double lo = t_prev, hi = t;
        for (int it = 0; it < 8; ++it) {
          const double mid = 0.5 * (lo + hi);
          double pm[3];
          for (int a = 0; a < 3; ++a) pm[a] = p0[a] + sgn * mid * dir[a];
          if ((indicator_linear(vol, pm) >= 0.5) == inside) lo = mid; else hi = mid;
        }
        const double tt = 0.5 * (lo + hi);
        for (int a = 0; a < 3; ++a) target[3 * size_t(v) + a] = u[a] + sgn * tt * normals[3 * size_t(v) + a];
        has[v] = 1;
        ++found;
        break;
      }
      t_prev = t;
    }
  }
  return found;
}

}  // namespace ffseg
