// What the engine keeps for each object between steps (its mesh, crop,
// intensity model and convergence), and what one step hands from stage to
// stage for it. The scratch that the objects share lives in StepScratch.
#pragma once
#include <cstdint>

#include "arena.h"
#include "bounding_region.h"
#include "convergence.h"
#include "cpu_dispatch.h"
#include "cubesphere.h"
#include "envelope_cholesky.h"
#include "fast_marching.h"
#include "fold_prevention.h"
#include "intensity_model.h"
#include "laplacian_system.h"
#include "mesh_contact.h"
#include "mesh_intersection.h"
#include "smoothing.h"
#include "step_guard.h"

namespace ffseg {

// One object's data between the stages of a step: every object is searched
// before any is deformed, so these are per object.
struct ObjectStep {
  double* target = nullptr;  // 3 nv: the correspondences v_i
  double* disp = nullptr;    // 3 nv: diffused, fold-limited displacements d_i
  uint8_t* has = nullptr;    // nv: vertex has a target / displacement
  uint8_t* border = nullptr; // nv: its target is the last sample before another object's region
  uint32_t found = 0;        // vertices with a target
  uint32_t far_out = 0;      // ... whose target lies more than a voxel away outward
  uint32_t far_in = 0;       // ... and inward (along the vertex normal)
  uint32_t borders = 0;      // border vertices (thesis 6.3)
  uint32_t flips_avoided = 0;
  uint32_t folds_avoided = 0;
  double guard_kept = 1;            // the mean share of the solved update the guard kept
  uint32_t guard_held = 0;          // vertices the guard held to less than half their update
  StepMotion motion;                // how the step moved the mesh
  // Several objects: the guard's cache of this object's accepted positions
  // (one object keeps its cache in the shared TriangleScratch).
  GuardCache guard;
  // regions: several objects, the border flags and the guard's cache too.
  void carve(Arena& a, const CubeSphere& m, bool regions);
};

struct Object {
  bool placed = false;
  // Some vertex found a boundary in a step since the object was placed (or
  // the volume or the parameters changed); flags: what its result lacks
  // (ObjectFlag), as of its last step. Both sit in the padding after placed.
  bool found_boundary = false;
  uint32_t flags = 0;
  double center[3] = {0, 0, 0};
  double radius = 0;
  double* x = nullptr;  // 3 * nv current vertex positions, mm
  // Grey-level targets: the smoothed crop around the mesh and the intensity
  // model learned from the initial sphere (fitted at the first step).
  SmoothedRoi roi;
  IntensityModel model;
  double kappa = 0;  // the conductance used, kept when the crop is recomputed
  // The first crop's SmoothedRoi::acquisition_scale(), kept as kappa is: the
  // scan's sampling, read where the statistics are read.
  double acquisition_scale = 1;
  // Several objects: the bounding region (its box and arrival times, thesis
  // 6.2), in the engine's array of every object's regions; else nullptr.
  RegionMap* region = nullptr;
  Convergence convergence;
  ObjectStep step;
  // Steps on: not converged (a converged object stays where it is).
  bool active() const { return placed && !convergence.converged(); }
};

// Per-step working memory the objects share (each stage runs over the
// objects one after the other).
struct StepScratch {
  double* normals = nullptr;  // 3 nv
  double* goal = nullptr;     // 3 nv: the positional targets of the solve
  double* tmp = nullptr;      // 3 nv
  double* rhs = nullptr;      // 3 nv (three columns)
  double* weight = nullptr;   // nv
  uint8_t* tmp_has = nullptr; // nv
  uint8_t* flipping = nullptr;// nv
  uint32_t* seq = nullptr;    // loop_len
  uint32_t* queue = nullptr;  // nv
  IntersectionScratch folds;
  TriangleScratch triangles;
  TwoRingGraph pattern;
  EnvelopeCholesky solver;
  LaplacianProgram program;  // the solver's entries as assembly writes them
  CpuDispatch cpu;           // the engine's kernels (the diffusion stage's)
  // Several objects: one front at a time marches in fm; seed_mask is its
  // crop's rasterised mesh.
  FastMarching fm;
  uint8_t* seed_mask = nullptr;
  const IntensityModel** models = nullptr;  // max_objects: the models competing in a front's speed
  // The other objects' meshes as obstacles of one object's guarded update
  // (the hard no-overlap guarantee), and their positions.
  ContactScratch contacts;
  const double** obstacles = nullptr;  // max_objects
  ObstacleSplits* obstacle_splits = nullptr;  // max_objects: their guard caches' splits
  void carve(Arena& a, const CubeSphere& m);
  void carve_regions(Arena& a, const CubeSphere& m, int64_t max_voxels, uint32_t max_objects);
};

}  // namespace ffseg
