#include "intensity_search.h"

#include <cmath>

namespace ffseg {

namespace {

// The partial-volume level of the header note. The ray is p(t) = p0 + sgn t d
// (index space); the g crossing lies at t, and the background side is at
// larger t when the vertex is inside (away = +1), at smaller t when it is
// outside (away = -1). Returns the crossing of the half-way level, or t.
double partial_volume_crossing(const SmoothedRoi& roi, const IntensityModel& model, const double p0[3],
                               const double d[3], double sgn, double away, double t, double step, uint32_t N,
                               uint32_t iterations) {
  // Smoothed intensity at distance sd beyond the g crossing, towards the background.
  auto value_at = [&](double sd, double* v) {
    const double q = t + away * sd;
    const double p[3] = {p0[0] + sgn * q * d[0], p0[1] + sgn * q * d[1], p0[2] + sgn * q * d[2]};
    if (!roi.inside_index(p)) return false;
    *v = roi.sample_index(p);
    return true;
  };
  double vg, vb, rival;
  if (!value_at(0, &vg) || !value_at(double(N) * step, &vb) || !model.rival_mean(vb, &rival)) return t;
  const double level = 0.5 * (model.class_mean(vg) + rival);
  const double side = rival > level ? 1.0 : -1.0;  // (v - level) * side >= 0: past the level
  if ((vg - level) * side >= 0) return t;           // the g crossing is already past it
  double lo = 0, hi = -1, v;
  for (uint32_t k = 1; k <= N; ++k) {
    if (!value_at(double(k) * step, &v)) return t;
    if ((v - level) * side >= 0) {
      hi = double(k) * step;
      break;
    }
    lo = double(k) * step;
  }
  if (hi < 0) return t;  // not reached within the N confirming steps
  for (uint32_t it = 0; it < iterations; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (value_at(mid, &v) && (v - level) * side < 0) lo = mid; else hi = mid;
  }
  return t + away * 0.5 * (lo + hi);
}

}  // namespace

__attribute__((flatten)) uint32_t search_intensity(const SmoothedRoi& roi, const IntensityModel& model, uint32_t nv, const double* x,
                          const double* normals, const IntensitySearchSettings& s, double* target, uint8_t* has,
                          const RegionLimit* region, uint8_t* border) {
  for (uint32_t v = 0; v < nv; ++v) has[v] = 0;
  if (border)
    for (uint32_t v = 0; v < nv; ++v) border[v] = 0;
  if (!roi.valid() || !model.valid() || !(s.range_mm > 0)) return 0;
  const double* sp = roi.spacing();
  double step = s.step_mm;
  if (!(step > 0)) step = 0.5 * std::fmin(sp[0], std::fmin(sp[1], sp[2]));
  const uint32_t N = s.consecutive_background ? s.consecutive_background : 1;
  const double Na = std::round(double(N) * s.acquisition_scale);
  const uint32_t N_acquired = Na > double(N) && Na < 1e6 ? uint32_t(Na) : N;
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
      bool at_border = false;
      for (int64_t i = 1; i <= M + int64_t(N); ++i) {
        // object_at(t)'s point (sgn is 1 here, and 1 t is t), computed once
        // for both tests.
        const double t = double(i) * step;
        const double p[3] = {p0[0] + t * d[0], p0[1] + t * d[1], p0[2] + t * d[2]};
        if (region && region->foreign(p)) {
          // Another object's region (thesis 6.3) reached. Past a boundary
          // already (background samples since j): that boundary, as if
          // confirmed. Else the last sample before it, a border vertex.
          if (run == 0) at_border = true;
          ok = true;
          ta = double(j) * step;
          tb = double(j + 1) * step;
          // (binary_search.cpp: no clearance; the step guard keeps the objects apart.)
          if (at_border) ta = tb = double(i - 1) * step;
          break;
        }
        if (intensity_object(roi, model, gamma, p)) {
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
    if (ta == tb) {  // a border vertex: no crossing to refine
      for (int a = 0; a < 3; ++a) target[3 * size_t(v) + a] = u[a] + ta * n[a];
      has[v] = 1;
      border[v] = 1;
      ++found;
      continue;
    }
    // ta has the vertex's state, tb the other one: bisect for the crossing.
    for (uint32_t it = 0; it < s.refine_iterations; ++it) {
      const double mid = 0.5 * (ta + tb);
      if (object_at(mid) == inside) ta = mid; else tb = mid;
    }
    double t = 0.5 * (ta + tb);
    if (s.partial_volume)
      t = partial_volume_crossing(roi, model, p0, d, sgn, inside ? 1.0 : -1.0, t, step, N_acquired, s.refine_iterations);
    for (int a = 0; a < 3; ++a) target[3 * size_t(v) + a] = u[a] + sgn * t * n[a];
    has[v] = 1;
    ++found;
  }
  return found;
}

}  // namespace ffseg
