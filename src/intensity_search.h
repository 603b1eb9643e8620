// Correspondence search on grey levels (thesis 5.3, eq. 5.3.1-5.3.2; METHOD.md
// section 3). A point is object when it lies in the smoothed crop and the
// intensity model's g of its (trilinearly interpolated, smoothed) intensity is
// at least Gamma (h = 1, eq. 5.3.2); points outside the crop are background.
// The thesis reads "the voxel containing u_i"; interpolation gives the same
// decision at voxel centres and a continuous crossing in between.
//
// Along each vertex normal, samples u_i at t_i = i * step_mm, i = 0, 1, ...:
//  - vertex in the object (h(u_0) = 1): search outward (+normal). The boundary
//    is the first j with t_j <= range_mm after which N consecutive samples are
//    background (eq. 5.3.1, N = consecutive_background); the confirming samples
//    may lie up to N steps beyond the range, so a boundary anywhere within the
//    range can be found.
//  - vertex in background (h(u_0) = 0, the mesh has overshot): search inward
//    (-normal) for the mirror event, the first sample j with t_j <= range_mm
//    that starts N consecutive object samples; the boundary lies just before it.
// The crossing is then refined by bisection of g - Gamma on [t_j, t_j+1]
// (outward) or [t_j-1, t_j] (inward). No such j: the vertex is solitary.
#pragma once
#include <cstdint>

#include "intensity_model.h"
#include "smoothing.h"

namespace ffseg {

struct IntensitySearchSettings {
  double range_mm = 20;                 // R_s
  double step_mm = 0;                   // sample spacing; <= 0: half the smallest voxel spacing
  double gamma = 0.05;                  // Gamma on the peak-normalised g, (0, 1)
  uint32_t consecutive_background = 3;  // N
  uint32_t refine_iterations = 8;       // bisection steps (step_mm / 256 with the default)
};

// h of eq. 5.3.2 at index-space point p.
inline bool intensity_object(const SmoothedRoi& roi, const IntensityModel& model, double gamma, const double p[3]) {
  return roi.inside_index(p) && model.g(roi.sample_index(p)) >= gamma;
}

// For every vertex (x, normals: 3 nv, mm; normals need not be unit): has[v] = 1
// and target[3v..] = the boundary point (mm), or has[v] = 0 (solitary). Returns
// the number of vertices with a target.
uint32_t search_intensity(const SmoothedRoi& roi, const IntensityModel& model, uint32_t nv, const double* x,
                          const double* normals, const IntensitySearchSettings& s, double* target, uint8_t* has);

}  // namespace ffseg
