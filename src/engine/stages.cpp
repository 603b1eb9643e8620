#include "stages.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "binary_search.h"
#include "diffusion.h"
#include "flips.h"
#include "grid_box.h"
#include "fold_prevention.h"
#include "intensity_search.h"
#include "laplacian_system.h"
#include "loop_spacing.h"
#include "normals.h"
#include "step_guard.h"

namespace ffseg {

namespace {

// Harmonic fill of the target-less gaps before diffusion: sweeps and the
// per-sweep change (mm) at which it stops.
constexpr uint32_t kFillSweeps = 200;
constexpr double kFillTolMm = 1e-3;

// Automatic diffusion rounds: 20 at n = 33, scaled with n^2 so that the
// displacement field is smoothed over the same share of the surface at every
// mesh resolution (a round spreads about one edge; edges shrink as 1/n).
// Measured on the cup: 20 rounds at n = 49 left the lid stuck (Dice 0.85),
// 44 reach 0.95-0.97; 8 at n = 21 do slightly better than 20.
uint32_t diffusion_rounds(uint32_t n) {
  const long r = std::lround(20.0 * (double(n) / 33.0) * (double(n) / 33.0));
  return r < 1 ? 1u : (r > 100 ? 100u : uint32_t(r));
}

// Polishing: once an object has come to rest, a twentieth of the rounds (at
// least one). Strong diffusion keeps large motions stable but also holds the
// mesh off sharp features (a rest where the *smoothed* displacement vanishes);
// near the surface little is needed. Measured on the cup: n = 49, alpha 0.3 /
// 0.7 from 0.954 / 0.967 to 0.979 / 0.997; n = 33 0.953 / 0.966 to 0.974 /
// 0.993.
uint32_t polish_rounds(uint32_t rounds) {
  const uint32_t r = uint32_t(std::lround(rounds / 20.0));
  return r < 1 ? 1u : r;
}

// How far the vertices moved (StepMotion): all of it, across the surface
// (along n, the unit normals where they were; without them all of it
// counts), and the fronts' advance toward targets more than a voxel away.
struct MotionTally {
  double still_mm;
  double voxel;
  double moved = 0, across = 0, advance = 0;
  uint32_t moving = 0, fronts = 0;
  void add(const double* from, const double* to, const double* n, const double* target) {
    double d[3], d2 = 0;
    for (int a = 0; a < 3; ++a) {
      d[a] = to[a] - from[a];
      d2 += d[a] * d[a];
    }
    const double len = std::sqrt(d2);
    moved += len;
    moving += len > still_mm;
    across += n ? std::fabs(d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) : len;
    if (!target) return;
    double q[3], q2 = 0;
    for (int a = 0; a < 3; ++a) {
      q[a] = target[a] - from[a];
      q2 += q[a] * q[a];
    }
    if (!(q2 > voxel * voxel)) return;
    ++fronts;
    advance += (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / std::sqrt(q2);
  }
  void store(uint32_t nv, ObjectStep& st) const {
    st.motion.mean_mm = moved / nv;
    st.motion.moving = moving;
    st.motion.normal_mm = across / nv;
    st.motion.front_mm = fronts ? advance / fronts : 0.0;
  }
};

}  // namespace

uint64_t now_us() {
  return uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::steady_clock::now().time_since_epoch())
                      .count());
}

void ObjectStep::carve(Arena& a, const CubeSphere& m, bool regions) {
  const uint32_t nv = m.nv;
  target = a.alloc<double>(size_t(3) * nv);
  disp = a.alloc<double>(size_t(3) * nv);
  has = a.alloc<uint8_t>(nv);
  border = regions ? a.alloc<uint8_t>(nv) : nullptr;
  if (regions) guard.carve(a, m);
}

void StepScratch::carve_regions(Arena& a, const CubeSphere& m, int64_t max_voxels, uint32_t max_objects) {
  fm.carve(a, max_voxels, false);
  seed_mask = a.alloc<uint8_t>(max_voxels > 0 ? size_t(max_voxels) : 0);
  models = a.alloc<const IntensityModel*>(max_objects);
  contacts.carve(a, m, max_objects - 1);
  obstacles = a.alloc<const double*>(max_objects);
  obstacle_splits = a.alloc<ObstacleSplits>(max_objects);
}

Err compute_object_region(const CubeSphere& m, const VolumeView& vol, const Params& p, Object& o,
                          const IntensityModel* const* models, uint32_t model_count, uint64_t models_epoch,
                          StepScratch& s, uint32_t step, char* msg, size_t msg_len) {
  RegionSpeed speed;
  if (p.target_mode == TargetMode::intensity) {
    speed.model = &o.model;
    speed.roi = &o.roi;
    speed.others = models;
    speed.other_count = model_count;
    speed.models_epoch = models_epoch;
  }
  const RegionStatus r =
      compute_region(m, o.x, vol, speed, p.region_width(), s.fm, s.seed_mask, *o.region, msg, msg_len);
  if (r == RegionStatus::too_large) return Err::roi_too_large;
  if (r != RegionStatus::ok) return Err::sphere_outside;
  o.region->computed_at = step;
  return Err::ok;
}

void hold_border_vertices(uint32_t nv, const double* x, ObjectStep& st) {
  st.borders = 0;
  if (st.border == nullptr) return;
  for (uint32_t v = 0; v < nv; ++v) {
    if (!st.border[v]) continue;
    if (!st.has[v]) {  // flip avoidance dropped its target: not held
      st.border[v] = 0;
      continue;
    }
    ++st.borders;
    for (int a = 0; a < 3; ++a) st.disp[3 * size_t(v) + a] = st.target[3 * size_t(v) + a] - x[3 * size_t(v) + a];
  }
}

Err compute_features(const VolumeView& vol, const Params& p, uint32_t nv, Object& o, char* msg, size_t msg_len) {
  const double range = p.range_mm();
  int64_t lo[3], hi[3];
  if (!o.model.valid())
    roi_box_for_ball(vol, o.center, o.radius + range, lo, hi);
  else
    roi_box_for_points(vol, o.x, nv, range, lo, hi);
  // The crop is recomputed only when the mesh outgrows it, with a search
  // range of slack where max_roi_voxels holds it (the slack saves
  // recomputations, the crop needs only the range).
  if (!o.roi.valid() || !o.roi.contains(lo, hi)) {
    int64_t need_lo[3], need_hi[3];
    for (int a = 0; a < 3; ++a) need_lo[a] = lo[a], need_hi[a] = hi[a];
    if (o.model.valid()) roi_box_for_points(vol, o.x, nv, 2 * range, lo, hi);
    SmoothingSettings sm;
    sm.iterations = p.smoothing_iterations;
    sm.kappa = o.model.valid() ? o.kappa : p.smoothing_kappa;
    // Once the model is fitted the box statistics are not read again: only the
    // first crop's (kept kappa, the model's variance floor) count.
    sm.statistics = !o.model.valid();
    // The statistics (noise, contrast range: the model's variance floor; the
    // scene's classes) come from the box of the search range around the
    // seed's centre, whatever the seed's radius: with the box of radius +
    // range, a 5 mm seed in a CT organ saw a bone plate 24 mm away that a 3 mm
    // seed did not, its floor grew from 12 to 42 HU and the organ took the
    // fluid of its cavities (issue 19's phantom, tests/engine/test_ct_phantom).
    int64_t slo[3], shi[3];
    if (!o.model.valid()) {
      roi_box_for_ball(vol, o.center, range, slo, shi);
      sm.stats_lo = slo;
      sm.stats_hi = shi;
    }
    // The crop with slack keeps to the object's own room; the crop it needs
    // may take more from a room the objects share (crop_pool.h).
    sm.share_room = !o.model.valid();
    RoiStatus rs = o.roi.compute(vol, lo, hi, sm, msg, msg_len);
    if (rs == RoiStatus::too_large && o.model.valid()) {
      sm.share_room = true;
      rs = o.roi.compute(vol, need_lo, need_hi, sm, msg, msg_len);
    }
    if (rs == RoiStatus::too_large) return Err::roi_too_large;
    if (rs == RoiStatus::empty) {
      std::snprintf(msg, msg_len, "step: the mesh has left the volume");
      return Err::sphere_outside;
    }
    if (rs != RoiStatus::ok) return Err::invalid_argument;
    o.kappa = o.roi.kappa();
    if (sm.statistics) o.acquisition_scale = o.roi.acquisition_scale();
  }
  if (!o.model.valid()) {
    IntensityModelSettings ms;
    ms.bin_radius = p.bin_radius;
    ms.bin_separation = p.bin_separation;
    ms.bin_min_count = p.bin_min_count;
    ms.sigma_floor_fraction = p.sigma_floor_fraction;
    ms.gamma = p.intensity_gamma;
    const ModelStatus ms_st = o.model.fit(o.roi, o.center, o.radius, ms, msg, msg_len, &vol);
    if (ms_st == ModelStatus::no_samples) return Err::sphere_outside;
    if (ms_st == ModelStatus::not_finite) return Err::numeric;
    if (ms_st != ModelStatus::ok) return Err::invalid_argument;
  }
  return Err::ok;
}

void search_correspondences(const CubeSphere& m, const VolumeView& vol, const Params& p, const Object& o,
                            const RegionLimit* region, double* normals, ObjectStep& st) {
  const uint32_t nv = m.nv;
  vertex_normals(m, o.x, normals);
  if (p.target_mode == TargetMode::binary) {
    SearchSettings ss;
    ss.range_mm = p.range_mm();
    ss.step_mm = p.search_step_mm > 0 ? p.search_step_mm : 0.5 * vol.min_spacing();
    st.found = search_binary(vol, nv, o.x, normals, ss, st.target, st.has, region, st.border);
  } else {
    IntensitySearchSettings is;
    is.range_mm = p.range_mm();
    is.step_mm = p.search_step_mm;
    is.gamma = p.intensity_gamma;
    is.consecutive_background = p.consecutive_background;
    is.partial_volume = o.convergence.refining();
    is.acquisition_scale = o.acquisition_scale;
    st.found = search_intensity(o.roi, o.model, nv, o.x, normals, is, st.target, st.has, region, st.border);
  }
  // A voxel: the largest spacing, so that a target inside the vertex's own
  // voxel in every direction is never far.
  const double voxel = vol.max_spacing();
  // A border vertex's target is another object's region, where a neighbour
  // holds it: a rest there is no stall. Nor is a target on the grid's face
  // (grid_box.h; the search ended there because the scan does, beyond reads
  // as background): the organ is cut there, not bounded, and the mesh's
  // flat cap on the face meets its walls in a rim the smoothness terms
  // round, so the rim's vertices rest short of the face's edge however long
  // the mesh steps (the shared CT's liver at 1 mm, n = 12, cut by the top
  // slice: at rest 45 such vertices up to 8 mm below the face; counted, its
  // net far share was 0.104, over the stall threshold, and it was reported
  // stalled; not counted, 0.052).
  const GridBox box(vol.dims());
  st.far_out = st.far_in = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    if (!st.has[v] || (st.border && st.border[v])) continue;
    double d2 = 0, dn = 0;
    for (int a = 0; a < 3; ++a) {
      const double q = st.target[3 * size_t(v) + a] - o.x[3 * size_t(v) + a];
      d2 += q * q;
      dn += q * normals[3 * size_t(v) + a];
    }
    if (d2 <= voxel * voxel) continue;
    double t[3];
    vol.world_to_index(st.target + 3 * size_t(v), t);
    if (box.at_face(t)) continue;
    st.far_out += dn > 0;
    st.far_in += dn <= 0;
  }
}

void avoid_contour_flips(const CubeSphere& m, const Params& p, const double* x, ObjectStep& st,
                         uint8_t* flipping, uint32_t* seq) {
  detect_flips(m, x, st.target, st.has, p.flip_tau, flipping);
  st.flips_avoided = avoid_flips(m, flipping, st.has, seq);
}

// Rounds are always even. One round, eq. 4.2.2, is the mean over a vertex and
// its four neighbours: on the quad grid it maps the checkerboard mode
// (neighbours displaced in opposite senses) to -0.6 times itself, so an odd
// number of rounds turns the finest ripple of the displacement field against
// itself and the step feeds a sawtooth instead of damping it. At rest that grew
// without bound (sphere phantom, one polishing round: Dice 0.999 -> 0.983 over
// 140 steps; Colin27 meshes at n = 12, three rounds: half their edges bent by
// more than 11 degrees, the guard refusing creases every step). An even count
// makes every mode's factor (1 + lambda)^(2k) / 25^k >= 0.
void diffuse_step(const CubeSphere& m, const Params& p, const double* x, bool polishing, ObjectStep& st,
                  StepScratch& s) {
  const uint32_t nv = m.nv;
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      st.disp[3 * size_t(v) + a] = st.has[v] ? st.target[3 * size_t(v) + a] - x[3 * size_t(v) + a] : 0.0;
  harmonic_fill(m, st.disp, st.has, s.queue, kFillSweeps, kFillTolMm);
  uint32_t rounds = p.diffusion_iterations ? p.diffusion_iterations : diffusion_rounds(m.n);
  if (polishing) rounds = polish_rounds(rounds);
  rounds += rounds & 1;
  diffuse_displacements(s.cpu, m, rounds, st.disp, st.has, s.tmp, s.tmp_has);
}

void prevent_step_folds(const CubeSphere& m, const Params& p, const double* x, ObjectStep& st, StepScratch& s) {
  st.folds_avoided = prevent_folds(m, x, st.disp, st.has, p.flip_tau, p.step_size, s.folds);
}

Err deform_step(const CubeSphere& m, const Params& p, const VolumeView* grid, double still_mm, bool respace,
                double* x, ObjectStep& st, StepScratch& s, const double* const* others, uint32_t other_count,
                const ObstacleSplits* other_splits,
                uint64_t stage_us[kStageCount], char* msg, size_t msg_len) {
  const uint32_t nv = m.nv;
  uint64_t t0 = now_us(), t1;
  auto lap = [&](int stage) {
    t1 = now_us();
    stage_us[stage] += t1 - t0;
    t0 = t1;
  };
  // p_i = u_i + alpha d_i, weights d_i / d_mean (eq. 4.2.6).
  const uint8_t* border = st.borders ? st.border : nullptr;
  positional_terms(nv, x, st.disp, st.has, p.step_size, p.lambda_position, s.goal, s.weight, s.tmp, border,
                   p.border_weight);
  // With the storage program (always, on the cube-sphere) only the values
  // are computed here: the factorisation stores them group by group.
  const bool fused = s.program.ok;
  if (fused)
    laplacian_values(p.lambda_laplacian, p.lambda_uniform, s.weight, s.program);
  else
    assemble_laplacian(m, p.lambda_laplacian, p.lambda_uniform, s.weight, s.solver, nullptr);
  laplacian_rhs(m, p.lambda_laplacian, p.lambda_uniform, x, s.goal, s.weight, s.rhs, s.tmp);
  lap(kStageAssembly);
  // The factorisation stores each row group's matrix entries, factors the
  // group and forward-substitutes the three right-hand sides in it while it
  // is in cache; the solve stage is the backward half.
  const int fr = fused ? s.solver.assign_factor_forward(s.program.off, s.program.val, s.program.count, s.rhs, nv)
                       : s.solver.factor_forward(s.rhs, nv);
  lap(kStageFactor);
  if (fr != EnvelopeCholesky::kOk) {
    std::snprintf(msg, msg_len, "step: factorisation failed (code %d, row %lld); mesh unchanged", fr,
                  (long long)s.solver.failed_row());
    return Err::numeric;
  }
  s.solver.solve_forwarded(s.rhs, nv);
  lap(kStageSolve);
  // A border vertex goes to its positional target and no further (thesis
  // 6.3): its weight already holds it there up to the solve's small give,
  // which must not carry it across the border.
  if (border)
    for (uint32_t v = 0; v < nv; ++v)
      if (border[v])
        for (int a = 0; a < 3; ++a) s.rhs[size_t(a) * nv + v] = s.goal[3 * size_t(v) + a];
  // Checked after the border targets are copied in: a target enters the
  // solve only through its weight, so a non-finite one (a weight that
  // rounded to 0 once made 0/0 of it) would pass a check of the solve alone.
  for (size_t q = 0; q < size_t(3) * nv; ++q)
    if (!std::isfinite(s.rhs[q])) {
      std::snprintf(msg, msg_len, "step: the solve produced non-finite positions; mesh unchanged");
      return Err::numeric;
    }
  // The loops re-spaced along themselves (loop_spacing.h; when:
  // Convergence::respacing()), so that a mesh growing into a tube or horn
  // brings vertices into it and a creased patch spreads. Between the solve
  // and the guard, s.tmp is free, and the guard checks the update as it
  // will be.
  if (respace && loop_spacing_scratch(m) <= 3 * uint64_t(nv)) respace_loops(m, s.rhs, kLoopRespacing, s.tmp);
  // The mesh ends at the scan's box (grid_box.h): a solve that carries a
  // vertex beyond it (the smoothness terms round a cap pressed on a face)
  // puts it back on the face, before the guard, which then checks the
  // update as it will be. The guard's held vertices move along the segment
  // from their old positions, inside the box, to these: the box being
  // convex, they stay inside too.
  // A mesh with no vertex in the box is a caller's sphere around the whole
  // scan: clamped, it would be crushed onto the box's edges and corners
  // (degenerate triangles, a mask of a third of the grid instead of the
  // whole-grid result the FILLS_GRID flag reports); it moves as before.
  bool any_inside = false;
  if (grid)
    for (uint32_t v = 0; v < nv && !any_inside; ++v) any_inside = in_grid(*grid, x + 3 * size_t(v));
  if (any_inside)
    for (uint32_t v = 0; v < nv; ++v) {
      double w[3] = {s.rhs[v], s.rhs[size_t(nv) + v], s.rhs[size_t(2) * nv + v]};
      if (clamp_to_grid(*grid, w))
        for (int a = 0; a < 3; ++a) s.rhs[size_t(a) * nv + v] = w[a];
    }
  // Several objects: the others' meshes are obstacles the update may not
  // touch (the hard no-overlap guarantee); the guard holds back the
  // vertices in contact as it does those of a fold or a crossing.
  ContactScratch* obstacles = nullptr;
  if (other_count > 0) {
    double region[6];
    guard_region(m, x, s.rhs, region);
    build_obstacles(m, others, other_count, s.contacts, region, other_splits);
    obstacles = &s.contacts;
  }
  st.guard_kept = guard_step(m, x, s.rhs, s.tmp, s.weight, s.tmp_has, s.flipping, s.triangles, obstacles,
                             st.guard.n ? &st.guard : nullptr);
  st.guard_held = 0;
  for (uint32_t v = 0; v < nv; ++v) st.guard_held += s.weight[v] < 0.5;  // the guard's shares
  lap(kStageGuard);
  // Re-spaced meshes rest on the motion across the surface and the fronts'
  // advance (convergence.cpp), measured against the mesh as it was.
  const double* normals = nullptr;
  if (respace) {
    vertex_normals(m, x, s.normals);
    normals = s.normals;
  }
  // A voxel: the largest spacing, as for the far targets of the stall rule.
  const bool fronts = respace && grid != nullptr;
  MotionTally tally{still_mm, fronts ? grid->max_spacing() : 0.0};
  for (uint32_t v = 0; v < nv; ++v) {
    double* xv = x + 3 * size_t(v);
    const double to[3] = {s.rhs[v], s.rhs[size_t(nv) + v], s.rhs[size_t(2) * nv + v]};
    const bool front = fronts && st.has[v] && !(st.border && st.border[v]);
    tally.add(xv, to, normals ? normals + 3 * size_t(v) : nullptr, front ? st.target + 3 * size_t(v) : nullptr);
    for (int a = 0; a < 3; ++a) xv[a] = to[a];
  }
  tally.store(nv, st);
  return Err::ok;
}

void naive_step(uint32_t nv, const Params& p, double still_mm, double* x, ObjectStep& st) {
  MotionTally tally{still_mm, 0.0};
  for (uint32_t v = 0; v < nv; ++v) {
    if (!st.has[v]) continue;
    double* xv = x + 3 * size_t(v);
    double to[3];
    for (int a = 0; a < 3; ++a) to[a] = xv[a] + p.step_size * (st.target[3 * size_t(v) + a] - xv[a]);
    tally.add(xv, to, nullptr, nullptr);
    for (int a = 0; a < 3; ++a) xv[a] = to[a];
  }
  tally.store(nv, st);
  st.flips_avoided = st.folds_avoided = 0;
}

}  // namespace ffseg
