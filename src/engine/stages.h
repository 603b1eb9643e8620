// The stages of one deformation step (thesis Algorithm 1), each for one
// object, in the order the data flows. The engine runs each stage over every
// active object before the next stage starts, so every object's mesh and
// features are known before any object searches (chapter 6's bounding
// regions go between features and search).
#pragma once
#include <cstddef>
#include <cstdint>

#include "cubesphere.h"
#include "errors.h"
#include "object.h"
#include "params.h"
#include "step_report.h"
#include "volume.h"

namespace ffseg {

// Chapter 5 features: the smoothed crop around the mesh o.x (recomputed only
// when the mesh outgrows it) and, once per sphere, the intensity model of the
// voxels inside it. Writes o.roi, o.model, o.kappa; on failure a message.
Err compute_features(const VolumeView& vol, const Params& p, uint32_t nv, Object& o, char* msg, size_t msg_len);

// Several objects (thesis 6.2): o's bounding region from its mesh o.x, with
// its features' speed (grey levels: against the scene and the placed
// objects' models, models[0..model_count), o's own among them or not) or
// the indicator's (binary), marched in s.fm. models_epoch: the sum of the
// generations of every model the engine holds (RegionSpeed::models_epoch;
// 0: unknown). Writes o.region; on failure a message (too large a box:
// roi_too_large).
Err compute_object_region(const CubeSphere& m, const VolumeView& vol, const Params& p, Object& o,
                          const IntensityModel* const* models, uint32_t model_count, uint64_t models_epoch,
                          StepScratch& s, uint32_t step, char* msg, size_t msg_len);

// Correspondences along the normals of x (thesis 4.2.2, 5.3): the binary
// crossing or, for grey levels, the boundary of the object's model (o's roi
// and model; partial-volume boundaries while refining). With region (several
// objects, 6.3) a ray stops before another object's region and st.border
// marks the vertex. Writes st.target, st.has, st.border and st.found;
// normals: 3 nv scratch.
void search_correspondences(const CubeSphere& m, const VolumeView& vol, const Params& p, const Object& o,
                            const RegionLimit* region, double* normals, ObjectStep& st);

// Border vertices (6.3) keep their own displacement towards their target,
// not the diffused one, so that the neighbours' pull cannot carry them over
// the border; counts them in st.borders (a border vertex whose target flip
// avoidance dropped is no longer one).
void hold_border_vertices(uint32_t nv, const double* x, ObjectStep& st);

// Flip detection and avoidance on the contours (4.2.3-4.2.4): clears st.has
// of all but the middle vertex of every run of flipping vertices; counts them
// in st.flips_avoided.
void avoid_contour_flips(const CubeSphere& m, const Params& p, const double* x, ObjectStep& st,
                         uint8_t* flipping, uint32_t* seq);

// Displacements d = v - u where a target exists, filled harmonically across
// the gaps and diffused (eq. 4.2.2) for an even number of rounds; fewer
// rounds while the object polishes. Writes st.disp (and the fill's st.has).
void diffuse_step(const CubeSphere& m, const Params& p, const double* x, bool polishing, ObjectStep& st,
                  StepScratch& s);

// Non-flipping self-intersections (fig. 4.7): halves disagreeing
// displacements in st.disp; counts them in st.folds_avoided.
void prevent_step_folds(const CubeSphere& m, const Params& p, const double* x, ObjectStep& st, StepScratch& s);

// The Laplacian deformation (4.2.5) towards x + alpha d, factorised and
// solved, and the guarded update: moves x (3 nv) to the new positions and
// records the motion in st.motion (vertices moving beyond still_mm; with
// respace, Convergence::respacing(), the loops are re-spaced and the motion
// across the surface and at the fronts recorded too). Times the assembly, factor, solve and guard stages into
// stage_us. others[0..other_count): the other objects' positions, which
// the update may not touch (their meshes, as they are when this object
// moves). other_splits (optional, one per other): their face splits where
// held (build_obstacles()). grid (optional): the volume whose box the new
// positions are clamped to before the guard (grid_box.h; a mesh inside it
// stays inside).
// On failure x is unchanged and msg says why.
Err deform_step(const CubeSphere& m, const Params& p, const VolumeView* grid, double still_mm, bool respace,
                double* x, ObjectStep& st, StepScratch& s, const double* const* others, uint32_t other_count,
                const ObstacleSplits* other_splits,
                uint64_t stage_us[kStageCount], char* msg, size_t msg_len);

// The naive variant of thesis fig. 4.10 (a test reference, through
// EngineTesting): vertices move straight towards their targets by alpha, no
// flip or fold handling, no solve.
void naive_step(uint32_t nv, const Params& p, double still_mm, double* x, ObjectStep& st);

// Microseconds on a steady clock, for the stage times.
uint64_t now_us();

}  // namespace ffseg
