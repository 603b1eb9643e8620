#include "engine.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "cubesphere_resample.h"
#include "mesh_contact.h"
#include "mesh_intersection.h"
#include "rasterize.h"
#include "stages.h"
#include "triangulation.h"

namespace ffseg {

// Doubles reserved for the envelope factor: measured stored entries per row
// are 5.06 n + 5 for n = 2..128 under RCM (a scan over those sizes,
// BENCHMARKS section 1); a closed form keeps the size query exact without
// building the mesh.
uint64_t solver_capacity(uint32_t n, uint32_t nv) {
  const uint64_t npad = (uint64_t(nv) + 3) / 4 * 4;
  return npad * (uint64_t(21 * n) / 4 + 24);
}

void StepScratch::carve(Arena& a, const CubeSphere& m) {
  const size_t nv = m.nv;
  normals = a.alloc<double>(3 * nv);
  goal = a.alloc<double>(3 * nv);
  tmp = a.alloc<double>(3 * nv);
  rhs = a.alloc<double>(3 * nv);
  weight = a.alloc<double>(nv);
  tmp_has = a.alloc<uint8_t>(nv);
  flipping = a.alloc<uint8_t>(nv);
  seq = a.alloc<uint32_t>(m.loop_len);
  queue = a.alloc<uint32_t>(nv);
  folds.carve(a, m.nv);
  triangles.carve(a, m);
  pattern.carve(a, m.nv);
  program.carve(a, m.nv);
}

void Engine::layout(Arena& a) {
  mesh_.carve(a, cfg_.mesh_resolution);
  const bool real = !a.measuring() && a.ok();
  if (real) mesh_.build();
  scratch_.carve(a, mesh_);
  const bool real2 = !a.measuring() && a.ok();
  if (real2) {
    scratch_.pattern.build(mesh_.nbr);
    scratch_.triangles.build_topology(mesh_);
  }
  scratch_.cpu = cpu_;
  if (!scratch_.solver.init(a, real2 ? scratch_.pattern.graph() : CsrGraph{mesh_.nv, nullptr, nullptr}, cpu_,
                            solver_capacity(mesh_.n, mesh_.nv)) &&
      real2)
    solver_failed_ = true;
  if (real2 && !solver_failed_) scratch_.program.build(mesh_, scratch_.solver);
  // Several objects: bounding regions (thesis chapter 6), one front at a
  // time in the shared marcher, each object's times in its own map.
  const bool regions = cfg_.max_objects > 1;
  if (regions) scratch_.carve_regions(a, mesh_, cfg_.region_voxels(), cfg_.max_objects);
  objects_ = a.alloc<Object>(cfg_.max_objects);
  region_maps_ = regions ? a.alloc<RegionMap>(cfg_.max_objects) : nullptr;
  // One object keeps its crop room to itself, as it always did; several
  // share theirs (a liver beside small organs holds more than its share).
  const bool grey = cfg_.target_mode == TargetMode::intensity;
  const bool shared_crops = grey && cfg_.max_objects > 1;
  if (shared_crops) {
    crops_.carve(a, int64_t(cfg_.max_objects) * cfg_.max_roi_voxels, cfg_.max_objects);
    crop_scratch_ = a.alloc<float>(size_t(SmoothedRoi::scratch_floats(crops_.capacity())));
  }
  Object probe;  // measuring pass: carve through a throw-away object
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    Object* o = objects_ ? new (&objects_[i]) Object() : &probe;
    o->x = a.alloc<double>(size_t(3) * mesh_.nv);
    // Grey-level buffers only when the configuration allows grey-level
    // targets: a binary-only engine never smooths a crop nor fits a model.
    if (grey) {
      if (shared_crops) o->roi.carve_in(crops_, i, cfg_.max_roi_voxels, crop_scratch_, cpu_);
      else o->roi.carve(a, cfg_.max_roi_voxels, cpu_);
      o->model.carve(a, IntensityModel::kDefaultSamples, cpu_);
    }
    o->step.carve(a, mesh_, regions);
    if (regions) {
      RegionMap probe_map;
      o->region = region_maps_ ? new (&region_maps_[i]) RegionMap() : &probe_map;
      o->region->carve(a, cfg_.region_voxels(), grey);
      if (!region_maps_) o->region = nullptr;
    }
  }
}

size_t Engine::workspace_bytes(const Config& c, unsigned char* image) {
  Arena a;
  a.alloc<Engine>(1);
  Engine probe;
  probe.cfg_ = c;
  probe.layout(a);
  if (image) std::memcpy(image, static_cast<const void*>(&probe), sizeof probe);
  return a.overflowed() ? 0 : a.used();
}

Engine* Engine::create(const Config& c, void* ws, size_t bytes) {
  Arena a(ws, bytes);
  void* at = a.alloc<Engine>(1);
  if (at == nullptr) return nullptr;
  Engine* e = new (at) Engine();
  e->cfg_ = c;
  e->cpu_ = CpuDispatch::detect();  // the engine's one choice of kernels
  e->layout(a);
  if (!a.ok() || e->solver_failed_) return nullptr;
  e->magic_ = kMagic;
  return e;
}

Err Engine::set_params(const Params& p) {
  if (p.target_mode == TargetMode::intensity && cfg_.target_mode == TargetMode::binary) {
    std::snprintf(msg_, kMsgLen,
                  "params.target_mode = intensity on an engine created binary-only (config.target_mode = "
                  "FFSEG_TARGET_BINARY reserves no grey-level buffers): create it with FFSEG_TARGET_INTENSITY");
    return Err::invalid_argument;
  }
  const Err r = check_params(p, msg_, kMsgLen);
  if (r == Err::ok) {
    params_ = p;
    for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
      objects_[i].convergence.restart();  // new terms: move again
      objects_[i].found_boundary = false;  // ... and look for a boundary under them
    }
  }
  return r;
}

Err Engine::set_volume(const VolumeDesc& d) {
  VolumeView v;
  if (!v.assign(d, msg_, kMsgLen)) return Err::invalid_volume;
  vol_ = v;
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    objects_[i].roi.invalidate();
    objects_[i].model.reset();
    if (objects_[i].region) objects_[i].region->valid = false;
    objects_[i].convergence.restart();
    objects_[i].found_boundary = false;
  }
  return Err::ok;
}

Err Engine::sample(const double w[3], uint32_t mode, double* value) const {
  char* msg = const_cast<char*>(msg_);  // the message is not part of the engine's state
  if (!vol_.valid()) {
    std::snprintf(msg, kMsgLen, "sample: no volume set (call ffseg_set_volume first)");
    return Err::misuse;
  }
  if (!std::isfinite(w[0]) || !std::isfinite(w[1]) || !std::isfinite(w[2])) {
    std::snprintf(msg, kMsgLen, "sample: the point (%g, %g, %g) mm is not finite", w[0], w[1], w[2]);
    return Err::invalid_argument;
  }
  if (mode == 0) *value = vol_.sample_nearest(w);
  else if (mode == 1) *value = vol_.sample_linear(w);
  else {
    std::snprintf(msg, kMsgLen, "sample: mode = %u is neither 0 (nearest) nor 1 (trilinear)", mode);
    return Err::invalid_argument;
  }
  return Err::ok;
}

Err Engine::check_object(uint32_t object, bool must_be_placed) const {
  if (object >= cfg_.max_objects) {
    std::snprintf(const_cast<char*>(msg_), kMsgLen, "object %u is not below max_objects = %u", object,
                  cfg_.max_objects);
    return Err::object_out_of_range;
  }
  if (must_be_placed && !objects_[object].placed) {
    std::snprintf(const_cast<char*>(msg_), kMsgLen, "object %u has no mesh yet: call ffseg_init_sphere first",
                  object);
    return Err::misuse;
  }
  return Err::ok;
}

Err Engine::init_sphere(uint32_t object, const double c[3], double r) {
  const Err e = check_seed("init_sphere", object, c, r);
  if (e != Err::ok) return e;
  double* sphere = scratch_.tmp;
  for (uint32_t v = 0; v < mesh_.nv; ++v)
    for (int d = 0; d < 3; ++d) sphere[3 * v + d] = c[d] + r * mesh_.unit[3 * v + d];
  // Several objects never overlap (the step guard keeps them apart from
  // here on): a sphere that crosses or encloses a placed object, or lies
  // inside one, is refused.
  const uint32_t hit = overlapped_object(object, sphere);
  if (hit < cfg_.max_objects) {
    std::snprintf(msg_, kMsgLen,
                  "init_sphere: the sphere (%g, %g, %g) r = %g mm overlaps object %u (objects of one engine never "
                  "overlap): place it apart",
                  c[0], c[1], c[2], r, hit);
    return Err::invalid_argument;
  }
  place(object, c, r, sphere);
  return Err::ok;
}

Err Engine::init_mesh(uint32_t object, const double c[3], double r, const float* xyz, uint32_t n_src) {
  const Err e = check_seed("init_mesh", object, c, r);
  if (e != Err::ok) return e;
  if (n_src < CubeSphere::kMinN || n_src > CubeSphere::kMaxN) {
    std::snprintf(msg_, kMsgLen, "init_mesh: the source mesh's resolution %u is outside %u..%u", n_src,
                  CubeSphere::kMinN, CubeSphere::kMaxN);
    return Err::invalid_argument;
  }
  const size_t ns = size_t(6) * n_src * n_src;
  for (size_t q = 0; q < 3 * ns; ++q)
    if (!std::isfinite(xyz[q])) {
      std::snprintf(msg_, kMsgLen, "init_mesh: vertex %zu of the source mesh is not finite", q / 3);
      return Err::invalid_argument;
    }
  double* x = scratch_.tmp;
  resample_cubesphere(mesh_, xyz, n_src, x);
  // The source mesh need not have come from an engine: a mesh that crosses
  // itself would void the step guard's promise from the first step.
  if (mark_intersections(mesh_, x, scratch_.triangles, nullptr) > 0) {
    std::snprintf(msg_, kMsgLen,
                  "init_mesh: the mesh resampled from resolution %u to %u crosses itself (is the source a "
                  "cube-sphere mesh in the engine's vertex order?)",
                  n_src, mesh_.n);
    return Err::invalid_argument;
  }
  const uint32_t hit = overlapped_object(object, x);
  if (hit < cfg_.max_objects) {
    std::snprintf(msg_, kMsgLen, "init_mesh: the mesh overlaps object %u (objects of one engine never overlap)", hit);
    return Err::invalid_argument;
  }
  place(object, c, r, x);
  return Err::ok;
}

Err Engine::check_seed(const char* call, uint32_t object, const double c[3], double r) {
  const Err oe = check_object(object, false);
  if (oe != Err::ok) return oe;
  if (!vol_.valid()) {
    std::snprintf(msg_, kMsgLen, "%s: no volume set (call ffseg_set_volume first)", call);
    return Err::misuse;
  }
  if (!std::isfinite(c[0]) || !std::isfinite(c[1]) || !std::isfinite(c[2])) {
    std::snprintf(msg_, kMsgLen, "%s: centre must be finite", call);
    return Err::invalid_argument;
  }
  if (!(r > 0) || !std::isfinite(r)) {
    std::snprintf(msg_, kMsgLen, "%s: radius %g mm must be positive and finite", call, r);
    return Err::invalid_argument;
  }
  if (!vol_.ball_meets_grid(c, r)) {
    std::snprintf(msg_, kMsgLen, "%s: the sphere (%g, %g, %g) r = %g mm does not meet the volume", call, c[0],
                  c[1], c[2], r);
    return Err::sphere_outside;
  }
  return Err::ok;
}

uint32_t Engine::overlapped_object(uint32_t object, const double* x) {
  const uint32_t none = cfg_.max_objects;
  if (cfg_.max_objects < 2) return none;
  uint32_t others = 0;
  for (uint32_t j = 0; j < cfg_.max_objects; ++j)
    if (j != object && objects_[j].placed) scratch_.obstacles[others++] = objects_[j].x;
  if (others == 0) return none;
  build_obstacles(mesh_, scratch_.obstacles, others, scratch_.contacts);
  if (mark_contacts(mesh_, x, scratch_.contacts, nullptr) == 0) return none;
  uint32_t hit = none;  // the first obstacle met, else the first placed one
  for (uint32_t k = 0, j = 0; j < cfg_.max_objects; ++j) {
    if (j == object || !objects_[j].placed) continue;
    if (hit == none) hit = j;
    if (scratch_.contacts.crossed[k++]) return j;
  }
  return hit;
}

void Engine::place(uint32_t object, const double c[3], double r, const double* x) {
  Object& o = objects_[object];
  for (size_t q = 0; q < size_t(3) * mesh_.nv; ++q) o.x[q] = x[q];
  for (int d = 0; d < 3; ++d) o.center[d] = c[d];
  o.radius = r;
  o.placed = true;
  o.found_boundary = false;
  o.flags = 0;
  o.convergence.reset();
  o.roi.invalidate();
  o.model.reset();
  if (o.region) o.region->valid = false;
}

Err Engine::extract_mesh(uint32_t object, float* xyz, size_t xyz_cap, uint32_t* tris, size_t tri_cap,
                         size_t* nv, size_t* nt) const {
  const Err oe = check_object(object, true);
  if (oe != Err::ok) return oe;
  const size_t NV = mesh_.nv, NT = mesh_.triangle_count();
  if (nv) *nv = NV;
  if (nt) *nt = NT;
  if (xyz == nullptr && tris == nullptr) return Err::ok;
  if ((xyz && xyz_cap < NV) || (tris && tri_cap < NT)) {
    std::snprintf(const_cast<char*>(msg_), kMsgLen,
                  "extract_mesh: buffers hold %zu vertices and %zu triangles, the mesh has %zu and %zu",
                  xyz ? xyz_cap : NV, tris ? tri_cap : NT, NV, NT);
    return Err::buffer_too_small;
  }
  const Object& o = objects_[object];
  if (xyz)
    for (size_t i = 0; i < 3 * NV; ++i) xyz[i] = float(o.x[i]);
  if (tris) triangulate(mesh_, o.x, tris);
  return Err::ok;
}

Err Engine::rasterize(uint32_t object, uint8_t* mask, const int64_t strides[3]) const {
  const Err oe = check_object(object, true);
  if (oe != Err::ok) return oe;
  if (!vol_.valid()) return Err::misuse;
  rasterize_mesh(mesh_, objects_[object].x, vol_, mask, strides);
  return Err::ok;
}

Err Engine::region_mask(uint32_t object, uint8_t* mask, const int64_t strides[3]) const {
  const Err oe = check_object(object, true);
  if (oe != Err::ok) return oe;
  char* msg = const_cast<char*>(msg_);
  if (!vol_.valid()) {
    std::snprintf(msg, kMsgLen, "region_mask: no volume set");
    return Err::misuse;
  }
  if (region_maps_ == nullptr) {
    std::snprintf(msg, kMsgLen,
                  "region_mask: a one-object engine (max_objects = 1) has no bounding regions");
    return Err::misuse;
  }
  const RegionMap& r = region_maps_[object];
  if (!r.valid) {
    std::snprintf(msg, kMsgLen,
                  "region_mask: object %u has no bounding region yet (regions are computed by ffseg_step "
                  "while two or more objects are placed, and again after ffseg_init_sphere or ffseg_set_volume)",
                  object);
    return Err::misuse;
  }
  const int64_t* D = vol_.dims();
  const int64_t s[3] = {strides ? strides[0] : 1, strides ? strides[1] : D[0], strides ? strides[2] : D[0] * D[1]};
  for (int64_t k = 0; k < D[2]; ++k)
    for (int64_t j = 0; j < D[1]; ++j)
      for (int64_t i = 0; i < D[0]; ++i) mask[i * s[0] + j * s[1] + k * s[2]] = 0;
  // Only voxels of the object's own box can be its (time_at is +inf beyond).
  const RegionSet set = regions();
  for (int64_t k = r.lo[2]; k < r.lo[2] + r.n[2]; ++k)
    for (int64_t j = r.lo[1]; j < r.lo[1] + r.n[1]; ++j)
      for (int64_t i = r.lo[0]; i < r.lo[0] + r.n[0]; ++i)
        if (set.owner(i, j, k) == object) mask[i * s[0] + j * s[1] + k * s[2]] = 1;
  return Err::ok;
}

}  // namespace ffseg

// ---- one deformation step (thesis Algorithm 1) ---------------------------------

namespace ffseg {

Err Engine::step(StepReport* r) {
  if (!vol_.valid()) {
    std::snprintf(msg_, kMsgLen, "step: no volume set (call ffseg_set_volume first)");
    return Err::misuse;
  }
  *r = StepReport();
  const uint32_t N = cfg_.max_objects, nv = mesh_.nv;
  uint32_t placed = 0;
  for (uint32_t i = 0; i < N; ++i) placed += objects_[i].placed;
  if (placed == 0) {
    std::snprintf(msg_, kMsgLen, "step: no object placed (call ffseg_init_sphere first)");
    return Err::misuse;
  }
  const Params& p = params_;
  // A converged object stays where it is: it has reached the rest the caller
  // asked for, and further steps would only cost time. Each stage below runs
  // over the active objects only.
  auto each_active = [&](auto&& f) -> Err {
    for (uint32_t i = 0; i < N; ++i)
      if (objects_[i].active()) {
        const Err e = f(objects_[i]);
        if (e != Err::ok) return e;
      }
    return Err::ok;
  };
  uint64_t t0 = now_us(), t1;
  auto lap = [&](int stage) {
    t1 = now_us();
    r->stage_us[stage] += t1 - t0;
    t0 = t1;
  };

  // 0. Features: the smoothed crop and the intensity model (grey levels).
  if (p.target_mode == TargetMode::intensity) {
    const Err e = each_active([&](Object& o) { return compute_features(vol_, p, nv, o, msg_, kMsgLen); });
    if (e != Err::ok) return e;
  }
  lap(kStageFeatures);
  // 0b. Several objects: the bounding regions (thesis 6.2), now that every
  // object's mesh and features are known and before any object searches.
  const bool regions = placed > 1 && cfg_.max_objects > 1;
  if (regions) {
    const Err e = update_regions();
    if (e != Err::ok) return e;
  }
  lap(kStageRegions);
  RegionSet set{nullptr, 0};
  if (regions) set = RegionSet{region_maps_, N};

  // 1. Correspondences along the normals (within the regions).
  for (uint32_t i = 0; i < N; ++i) {
    Object& o = objects_[i];
    if (!o.active()) continue;
    const RegionLimit limit{&set, &vol_, i};
    search_correspondences(mesh_, vol_, p, o, regions ? &limit : nullptr, scratch_.normals, o.step);
  }
  lap(kStageSearch);

  if (naive_) {
    each_active([&](Object& o) {
      naive_step(nv, p, o.convergence.moving_threshold(rule(o)), o.x, o.step);
      return Err::ok;
    });
  } else {
    // 2-3. Flip detection and avoidance on the contours.
    each_active([&](Object& o) {
      avoid_contour_flips(mesh_, p, o.x, o.step, scratch_.flipping, scratch_.seq);
      return Err::ok;
    });
    lap(kStageFlips);
    // 4. Diffusion of the displacements.
    each_active([&](Object& o) {
      diffuse_step(mesh_, p, o.x, o.convergence.polishing(), o.step, scratch_);
      if (regions) hold_border_vertices(nv, o.x, o.step);
      return Err::ok;
    });
    lap(kStageDiffusion);
    // 5. Non-flipping self-intersections: shorten disagreeing displacements.
    each_active([&](Object& o) {
      prevent_step_folds(mesh_, p, o.x, o.step, scratch_);
      return Err::ok;
    });
    lap(kStageIntersection);
    // 6. Laplacian deformation, solve and guarded update (times its own
    // assembly, factor, solve and guard stages).
    for (uint32_t i = 0; i < N; ++i) {
      Object& o = objects_[i];
      if (!o.active()) continue;
      // Every other placed object, as it is now (moved already this step or not).
      uint32_t others = 0;
      if (placed > 1)
        for (uint32_t j = 0; j < N; ++j)
          if (j != i && objects_[j].placed) {
            // Its guard's splits at the positions that guard accepted:
            // build_obstacles() takes them where these are still its own.
            const GuardCache& g = objects_[j].step.guard;
            scratch_.obstacle_splits[others] = {g.valid ? g.alt : nullptr, g.key};
            scratch_.obstacles[others++] = objects_[j].x;
          }
      const Err e = deform_step(mesh_, p, &vol_, o.convergence.moving_threshold(rule(o)),
                                o.convergence.respacing(rule(o)), o.x, o.step, scratch_,
                                scratch_.obstacles, others, scratch_.obstacle_splits, r->stage_us, msg_, kMsgLen);
      if (e != Err::ok) return e;
    }
  }

  // 7. Convergence, object by object, and the report of the first objects.
  // An object at rest is not necessarily segmented: a mesh that never met a
  // boundary only stood still, and one holding most of the grid swallowed
  // the background, and one held in place while its targets still lie
  // beyond it has stalled. Its flags say so; they change only while it moves.
  bool all_converged = true;
  uint32_t slot = 0;
  for (uint32_t i = 0; i < N; ++i) {
    Object& o = objects_[i];
    if (!o.placed) continue;
    const uint32_t at = slot++;  // report slots follow the placed objects
    if (!o.convergence.converged()) {
      if (o.step.found > 0) o.found_boundary = true;
      o.flags = (o.found_boundary ? 0u : uint32_t(kObjectNoBoundary)) |
                (mesh_fills_grid(mesh_, o.x, vol_, kFillsGridFraction) ? uint32_t(kObjectFillsGrid) : 0u);
    }
    const bool moved = !o.convergence.converged();
    const ObjectStep& st = o.step;
    if (moved) {
      if (at < kReportObjects) {
        r->moving[at] = st.motion.moving;
        r->mean_displacement_mm[at] = st.motion.mean_mm;
        r->with_target[at] = st.found;
        r->flips_avoided[at] = st.flips_avoided;
        r->folds_avoided[at] = st.folds_avoided;
        r->border_vertices[at] = regions ? st.borders : 0;
        r->guard_held[at] = st.guard_held;
        r->far_outward[at] = st.far_out;
        r->far_inward[at] = st.far_in;
        r->respaced[at] = o.convergence.respacing(rule(o)) ? 1u : 0u;  // the state this step ran in
      }
      if (!o.convergence.record(rule(o), st.motion, nv,
                                (double(st.far_out) - double(st.far_in)) / nv))
        all_converged = false;
      if (o.convergence.stalled()) o.flags |= kObjectStalled;
    }
    if (at < kReportObjects) r->object_flags[at] = o.flags;
    r->flags_all |= o.flags;
  }
  ++steps_;
  r->step_index = steps_;
  r->active_objects = placed;
  if (!all_converged) return Err::ok;
  return r->flags_all != 0 ? Err::degenerate : Err::converged;
}

// Each placed object's region is recomputed when it has none, every
// region_interval steps while the object moves, and at once when its mesh
// comes within half the width of its box (a mesh cannot outrun its region
// between two recomputations: a step moves it by at most alpha times the
// search range). A converged object's mesh stays, and so does its region.
Err Engine::update_regions() {
  const Params& p = params_;
  const double w = p.region_width();
  uint32_t nmodels = 0;  // every placed object's model competes in the others' speeds
  uint64_t epoch = 0;    // every model's generation counts, placed or not (RegionSpeed::models_epoch)
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    if (objects_[i].placed && objects_[i].model.valid()) scratch_.models[nmodels++] = &objects_[i].model;
    epoch += objects_[i].model.generation();
  }
  if (speed_tables_ != 0) epoch = speed_tables_ == 1 ? 0 : 1;  // tests only (EngineTesting)
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    Object& o = objects_[i];
    if (!o.placed) continue;
    RegionMap& r = *o.region;
    const bool stale = !r.valid || (o.active() && (steps_ + 1 - r.computed_at >= p.region_interval ||
                                                   !r.holds(vol_, o.x, mesh_.nv, 0.5 * w)));
    if (!stale) continue;
    const Err e = compute_object_region(mesh_, vol_, p, o, scratch_.models, nmodels, epoch, scratch_, steps_ + 1,
                                        msg_, kMsgLen);
    if (e != Err::ok) return e;
  }
  return Err::ok;
}

ConvergenceRule Engine::rule(const Object& o) const {
  ConvergenceRule c;
  c.convergence_mm = params_.convergence_mm;
  c.binary = params_.target_mode == TargetMode::binary;
  c.partial_volume_steps = params_.partial_volume_steps;
  // Automatic: free growth where the object's boundary is in view of its
  // box (intensity_model.h), a tube or horn of its own contrast; elsewhere
  // free growth is a leak as often as an organ.
  c.boundary_in_view = o.model.boundary_in_view();
  c.grey_respacing = params_.grey_respacing == 1 || (params_.grey_respacing == 0 && c.boundary_in_view);
  return c;
}

}  // namespace ffseg
