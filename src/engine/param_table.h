// The one list of the engine's parameters. Everything that names them is
// generated from it: the engine's Params (params.h) and their check
// (params.cpp), the C API's ffseg_params_init_default and the copy in
// ffseg_set_params (capi/), and the CLI's --param table (tools/cli/). The
// public struct ffseg_params in include/ffseg.h keeps its own documented
// declaration (the header must stand alone); tests/engine/test_params.cpp
// checks that it, this table and the CLI agree field by field.
//
// FFSEG_PARAM_TABLE(X) calls X once per field, in ffseg_params' order (the
// reserved fields, which the C API refuses when non-zero, are not in it):
//   X(name, ctype, kind, default, lo, hi, bounds, unit, doc)
//   ctype   the field's type in ffseg::Params
//   kind    U32 or F64: the field's type in ffseg_params
//   default the value both structs start with
//   lo, hi  the accepted range, closed or open at each end as `bounds` says:
//           CC [lo, hi], OC (lo, hi], CO [lo, hi), OO (lo, hi); U32 fields are
//           always CC (written lo..hi)
//   unit    "" when the value has none
//   doc     one line (include/ffseg.h has the full text)
//
// Plain macros and literals only: the CLI includes this file without seeing
// the engine's types (ctype is only expanded where ffseg::Params is known).
#pragma once
#include <cmath>
#include <cstdint>
#include <cstdio>

#define FFSEG_PARAM_TABLE(X)                                                                              \
  X(target_mode, TargetMode, U32, 0, 0, 1, CC, "",                                                        \
    "0 = binary (non-zero voxels are the object), 1 = intensity (grey levels, chapter 5)")                \
  X(lambda_laplacian, double, F64, 1.0, 0, 1e6, OC, "", "lambda_L, Laplacian preservation")               \
  X(lambda_position, double, F64, 1.0, 1e-6, 1e6, CC, "", "lambda_p, positional constraints")            \
  X(lambda_uniform, double, F64, 0.25, 0, 1e6, CC, "", "lambda_u, uniform edge length on the contours")    \
  X(step_size, double, F64, 0.5, 0, 1, OC, "", "alpha: p_i = u_i + alpha (v_i - u_i)")                    \
  X(flip_tau, double, F64, 0.2, 0, 1, CO, "", "tau of eq. 4.2.1: an edge flips when cos <= tau")          \
  X(search_range_mm, double, F64, 0.0, 0, 1e4, CC, "mm",                                                  \
    "search along the normal; 0 = automatic (80 mm binary, 20 mm grey levels)")                           \
  X(search_step_mm, double, F64, 0.0, 0, 100, CC, "mm",                                                   \
    "sample spacing along the normal; 0 = half the smallest voxel spacing")                              \
  X(convergence_mm, double, F64, 0.05, 0, 100, CC, "mm", "converged when the mean displacement is below")  \
  X(diffusion_iterations, uint32_t, U32, 0, 0, 100, CC, "",                                               \
    "rounds of displacement averaging (eq. 4.2.2); 0 = automatic, 20 (n / 33)^2")                         \
  X(consecutive_background, uint32_t, U32, 3, 1, 64, CC, "", "N of thesis 5.3")                           \
  X(smoothing_iterations, uint32_t, U32, 5, 0, 100, CC, "", "Perona-Malik steps on the crop (eq. 5.2.1)") \
  X(bin_min_count, uint32_t, U32, 0, 0, 2147483648.0, CC, "samples",                                      \
    "N_m of adaptive binning (Algorithm 2); 0 = max(8, 5% of the sphere's samples)")                     \
  X(smoothing_kappa, double, F64, 0.0, 0, 1e9, CC, "intensity/mm",                                        \
    "conductance contrast K of eq. 5.2.2; 0 = from the region's noise")                                   \
  X(intensity_gamma, double, F64, 0.2, 0, 1, OO, "", "Gamma: object where g(x) >= Gamma")                 \
  X(sigma_floor_fraction, double, F64, 0.04, 0, 1, CC, "",                                                \
    "lower bound on each Gaussian's sigma, fraction of the 1st-99th percentile range")                   \
  X(bin_radius, double, F64, 0.0, 0, 1e9, CC, "intensity", "R of Algorithm 2; 0 = 2 x the sigma floor")   \
  X(bin_separation, double, F64, 0.0, 0, 1e9, CC, "intensity", "S of Algorithm 2; 0 = 4 x the sigma floor") \
  X(partial_volume_steps, uint32_t, U32, 4, 0, 1000, CC, "steps",                                         \
    "grey levels: steps with partial-volume boundaries after rest; 0 = off")                              \
  X(region_width_mm, double, F64, 0.0, 0, 1000, CC, "mm",                                                 \
    "several objects: w_i, a region's box beyond its mesh (eq. 6.2.6); 0 = automatic, 10 mm")             \
  X(border_weight, double, F64, 1000.0, 0, 1e9, OC, "",                                                   \
    "several objects: a border vertex's positional weight, times lambda_p (thesis 6.3)")                  \
  X(region_interval, uint32_t, U32, 4, 1, 1000, CC, "steps",                                              \
    "several objects: steps between recomputations of the bounding regions")                              \
  X(grey_respacing, uint32_t, U32, 0, 0, 2, CC, "",                                                       \
    "grey levels: re-space the contour loops until the first rest (growth along tubes); "                 \
    "0 = where the boundary is in view, 1 = always, 2 = never")

namespace ffseg {

enum class ParamKind : unsigned { U32, F64 };
enum class ParamBounds : unsigned { CC, OC, CO, OO };  // closed / open at (lo, hi)

// One row of the table, for code that walks the parameters at run time.
struct ParamSpec {
  const char* name;
  ParamKind kind;
  double default_value;
  double lo, hi;
  ParamBounds bounds;
  const char* unit;
  const char* doc;
};

#define FFSEG_PARAM_SPEC(name, ctype, kind, def, lo, hi, bounds, unit, doc) \
  {#name, ParamKind::kind, double(def), double(lo), double(hi), ParamBounds::bounds, unit, doc},
inline constexpr ParamSpec kParamSpecs[] = {FFSEG_PARAM_TABLE(FFSEG_PARAM_SPEC)};
#undef FFSEG_PARAM_SPEC
inline constexpr unsigned kParamCount = sizeof(kParamSpecs) / sizeof(kParamSpecs[0]);

// Whether v lies in the spec's range (false for NaN and infinities).
inline bool param_in_range(const ParamSpec& s, double v) {
  if (!(v == v) || v - v != 0) return false;  // NaN, +-inf
  const bool lo_ok = (s.bounds == ParamBounds::CC || s.bounds == ParamBounds::CO) ? v >= s.lo : v > s.lo;
  const bool hi_ok = (s.bounds == ParamBounds::CC || s.bounds == ParamBounds::OC) ? v <= s.hi : v < s.hi;
  return lo_ok && hi_ok;
}

// A bound as include/ffseg.h writes it: powers of ten from 1e4 and up to 1e-4 as "1eK",
// 2^31 as "2^31", anything else as %g.
inline void param_bound_text(double v, char* buf, unsigned len) {
  const double k = std::log10(v);
  if ((v >= 1e4 || (v > 0 && v <= 1e-4)) && k == std::floor(k)) std::snprintf(buf, len, "1e%d", int(k));
  else if (v == 2147483648.0) std::snprintf(buf, len, "2^31");
  else std::snprintf(buf, len, "%g", v);
}

// The range as the header writes it: "(0, 1e6]" for doubles, "1..64" for
// integers. Returns buf (at least 48 chars).
inline const char* param_range_text(const ParamSpec& s, char* buf, unsigned len) {
  char lo[16], hi[16];
  param_bound_text(s.lo, lo, sizeof lo);
  param_bound_text(s.hi, hi, sizeof hi);
  if (s.kind == ParamKind::U32) {
    std::snprintf(buf, len, "%s..%s", lo, hi);
  } else {
    const bool lc = s.bounds == ParamBounds::CC || s.bounds == ParamBounds::CO;
    const bool hc = s.bounds == ParamBounds::CC || s.bounds == ParamBounds::OC;
    std::snprintf(buf, len, "%c%s, %s%c", lc ? '[' : '(', lo, hi, hc ? ']' : ')');
  }
  return buf;
}

}  // namespace ffseg
