#include "intensity_search.h"

#include <cmath>

namespace ffseg {

__attribute__((flatten)) uint32_t search_intensity(const SmoothedRoi& roi, const IntensityModel& model, uint32_t nv, const double* x,
                          const double* normals, const IntensitySearchSettings& s, double* target, uint8_t* has) {
  for (uint32_t v = 0; v < nv; ++v) has[v] = 0;
  if (!roi.valid() || !model.valid() || !(s.range_mm > 0)) return 0;
  const double* sp = roi.spacing();
  double step = s.step_mm;
  if (!(step > 0)) step = 0.5 * std::fmin(sp[0], std::fmin(sp[1], sp[2]));
  const uint32_t N = s.consecutive_background ? s.consecutive_background : 1;
  const double Mf = std::floor(s.range_mm / step + 1e-9);
  if (!(Mf < 1e7)) return 0;  // absurd range/step ratio
  const int64_t M = int64_t(Mf);
  const double gamma = s.gamma;
  uint32_t found = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    const double* u = x + 3 * size_t(v);
    const double* nw = normals + 3 * size_t(v);
    const double len = std::sqrt(nw[0] * nw[0] + nw[1] * nw[1] + nw[2] * nw[2]);
    if (!(len > 0 && std::isfinite(len) && std::isfinite(u[0]) && std::isfinite(u[1]) && std::isfinite(u[2])))
      continue;
    const double n[3] = {nw[0] / len, nw[1] / len, nw[2] / len};
    double p0[3], d[3];
    roi.world_to_index(u, p0);
    roi.world_dir_to_index(n, d);
    const bool inside = intensity_object(roi, model, gamma, p0);
    const double sgn = inside ? 1.0 : -1.0;  // outward from the object, inward from background
    auto object_at = [&](double t) {
      const double p[3] = {p0[0] + sgn * t * d[0], p0[1] + sgn * t * d[1], p0[2] + sgn * t * d[2]};
      return intensity_object(roi, model, gamma, p);
    };
    double ta = 0, tb = 0;
    bool ok = false;
    if (inside) {
      // Last object sample j followed by N background samples (eq. 5.3.1).
      int64_t j = 0;
      uint32_t run = 0;
      for (int64_t i = 1; i <= M + int64_t(N); ++i) {
        if (object_at(double(i) * step)) {
          j = i;
          run = 0;
          if (j > M) break;
        } else if (++run == N) {
          ok = true;
          ta = double(j) * step;
          tb = double(j + 1) * step;
          break;
        }
      }
    } else {
      // First sample j that starts N object samples.
      int64_t start = 0;
      uint32_t run = 0;
      for (int64_t i = 1; i <= M + int64_t(N) - 1; ++i) {
        if (object_at(double(i) * step)) {
          if (run == 0) start = i;
          if (++run == N) {
            ok = true;
            ta = double(start - 1) * step;
            tb = double(start) * step;
            break;
          }
        } else {
          run = 0;
          if (i >= M) break;  // a run starting later would begin beyond the range
        }
      }
    }
    if (!ok) continue;
    // ta has the vertex's state, tb the other one: bisect for the crossing.
    for (uint32_t it = 0; it < s.refine_iterations; ++it) {
      const double mid = 0.5 * (ta + tb);
      if (object_at(mid) == inside) ta = mid; else tb = mid;
    }
    const double t = 0.5 * (ta + tb);
    for (int a = 0; a < 3; ++a) target[3 * size_t(v) + a] = u[a] + sgn * t * n[a];
    has[v] = 1;
    ++found;
  }
  return found;
}

}  // namespace ffseg
