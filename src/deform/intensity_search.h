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
//
// Partial-volume level (partial_volume = true). The g crossing is where the
// object's likelihood gives up, not where the tissue changes: between a
// caudate of 88 and CSF of 33 (Colin27) g = Gamma at 79, 16% of the way into
// the blurred edge, so a mesh on the g crossings sits inside the organ by
// about a third of the edge's width wherever a distant class borders it. A
// voxel at the edge is mostly object while its value is nearer the object's
// class than the neighbour's: the boundary is the half-way level
//   (mu_object + mu_rival) / 2,
// mu_object the mean of the object component most probable at the g
// crossing, mu_rival the mean of the scene's competing class that claims
// (Bayes rule of intensity_model.h) the sample N steps beyond the crossing on
// the background side. The crossing moves there, away from the object, when
// the level is reached within those N steps (bisected like the g crossing);
// it stays put when no competing class claims the background (a weak edge
// against a similar tissue: no class to be half-way to), when the g crossing
// is already past the level (a close neighbour: the Bayes cut comes first),
// or when the level is not reached within N steps. The vertex's own state
// (inside or outside) is still decided by g, so the rule only ever moves a
// boundary by at most N samples away from the object. The engine uses it for
// a few steps once an object has come to rest (Params::partial_volume_steps).
// On a grid finer than the scan was acquired on (the 1 mm CT made from 3 mm)
// an edge is as wide in mm as the acquisition made it, three times as many
// grid samples: N grid samples beyond the g crossing lie inside the edge,
// where the object's class, not a rival, is the most probable, and the rule
// left every boundary on its g crossing, a millimetre inside the label's
// (BENCHMARKS.md section 12). The N samples are therefore the scan's own:
// N * acquisition_scale grid samples (rounded), N on a scan's own grid.
#pragma once
#include <cstdint>

#include "bounding_region.h"
#include "intensity_model.h"
#include "smoothing.h"

namespace ffseg {

// R_s when params.search_range_mm is 0 (automatic): grey-level targets search
// a shorter way than binary ones (each sample reads the intensity model).
constexpr double kIntensitySearchRangeMm = 20;

struct IntensitySearchSettings {
  double range_mm = kIntensitySearchRangeMm;  // R_s
  double step_mm = 0;                   // sample spacing; <= 0: half the smallest voxel spacing
  double gamma = 0.2;                   // Gamma on the peak-normalised g, (0, 1): Params' default
  uint32_t consecutive_background = 3;  // N
  uint32_t refine_iterations = 8;       // bisection steps (step_mm / 256 with the default)
  bool partial_volume = false;          // boundary at the half-way level (see above)
  // Grid samples per acquired sample (SmoothedRoi::acquisition_scale): the
  // partial-volume level is sought within N acquired samples.
  double acquisition_scale = 1;
};

// h of eq. 5.3.2 at index-space point p.
inline bool intensity_object(const SmoothedRoi& roi, const IntensityModel& model, double gamma, const double p[3]) {
  return roi.inside_index(p) && model.g(roi.sample_index(p)) >= gamma;
}

// For every vertex (x, normals: 3 nv, mm; normals need not be unit): has[v] = 1
// and target[3v..] = the boundary point (mm), or has[v] = 0 (solitary). Returns
// the number of vertices with a target.
// With region (several objects, thesis 6.3; border then required): an
// outward ray that reaches a sample of another object's region before its
// boundary stops at the sample before it, the target, and border[v] = 1; a
// boundary found before the other region stays (border[v] = 0).
uint32_t search_intensity(const SmoothedRoi& roi, const IntensityModel& model, uint32_t nv, const double* x,
                          const double* normals, const IntensitySearchSettings& s, double* target, uint8_t* has,
                          const RegionLimit* region = nullptr, uint8_t* border = nullptr);

}  // namespace ffseg
