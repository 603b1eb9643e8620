#include "engine.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "correspondence.h"
#include "diffusion.h"
#include "flips.h"
#include "intensity_search.h"
#include "laplacian_system.h"
#include "normals.h"
#include "rasterize.h"
#include "step_guard.h"

namespace ffseg {

namespace {
constexpr uint32_t kMaxObjects = 64;
constexpr int64_t kMaxRoi = int64_t(1) << 40;

bool in_range(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }
bool in_open_closed(double v, double lo, double hi) { return std::isfinite(v) && v > lo && v <= hi; }
}  // namespace

Err check_config(const Config& c, char* msg, size_t n) {
  if (c.max_objects < 1 || c.max_objects > kMaxObjects) {
    std::snprintf(msg, n, "config.max_objects = %u is outside 1..%u", c.max_objects, kMaxObjects);
    return Err::invalid_argument;
  }
  if (c.mesh_resolution < CubeSphere::kMinN || c.mesh_resolution > CubeSphere::kMaxN) {
    std::snprintf(msg, n, "config.mesh_resolution = %u is outside %u..%u", c.mesh_resolution,
                  CubeSphere::kMinN, CubeSphere::kMaxN);
    return Err::invalid_argument;
  }
  if (c.max_roi_voxels < 0 || c.max_roi_voxels > kMaxRoi) {
    std::snprintf(msg, n, "config.max_roi_voxels = %lld is outside 0..2^40", (long long)c.max_roi_voxels);
    return Err::invalid_argument;
  }
  return Err::ok;
}

Err check_params(const Params& p, char* msg, size_t n) {
  const char* bad = nullptr;
  if (p.target_mode != TargetMode::binary && p.target_mode != TargetMode::intensity) bad = "target_mode (0 or 1)";
  else if (!in_open_closed(p.lambda_laplacian, 0, 1e6)) bad = "lambda_laplacian (0, 1e6]";
  else if (!in_open_closed(p.lambda_position, 0, 1e6)) bad = "lambda_position (0, 1e6]";
  else if (!in_range(p.lambda_uniform, 0, 1e6)) bad = "lambda_uniform [0, 1e6]";
  else if (!in_open_closed(p.step_size, 0, 1)) bad = "step_size (0, 1]";
  else if (!(in_range(p.flip_tau, 0, 1) && p.flip_tau < 1)) bad = "flip_tau [0, 1)";
  else if (!in_range(p.search_range_mm, 0, 1e4)) bad = "search_range_mm [0, 1e4]";
  else if (!in_range(p.search_step_mm, 0, 100)) bad = "search_step_mm [0, 100]";
  else if (!in_range(p.convergence_mm, 0, 100)) bad = "convergence_mm [0, 100]";
  else if (p.diffusion_iterations > 100) bad = "diffusion_iterations 0..100";
  else if (p.partial_volume_steps > 1000) bad = "partial_volume_steps 0..1000";
  else if (p.consecutive_background < 1 || p.consecutive_background > 64) bad = "consecutive_background 1..64";
  else if (p.smoothing_iterations > 100) bad = "smoothing_iterations 0..100";
  else if (p.bin_min_count > (1u << 31)) bad = "bin_min_count 0..2^31";
  else if (!in_range(p.smoothing_kappa, 0, 1e9)) bad = "smoothing_kappa [0, 1e9]";
  else if (!(in_range(p.intensity_gamma, 0, 1) && p.intensity_gamma > 0 && p.intensity_gamma < 1)) bad = "intensity_gamma (0, 1)";
  else if (!in_range(p.sigma_floor_fraction, 0, 1)) bad = "sigma_floor_fraction [0, 1]";
  else if (!in_range(p.bin_radius, 0, 1e9)) bad = "bin_radius [0, 1e9]";
  else if (!in_range(p.bin_separation, 0, 1e9)) bad = "bin_separation [0, 1e9]";
  if (bad) {
    std::snprintf(msg, n, "params.%s: value out of range", bad);
    return Err::invalid_argument;
  }
  return Err::ok;
}

// Doubles reserved for the envelope factor: measured stored entries per row
// are 5.06 n + 5 for n = 2..128 under RCM (tests/test_deform.cpp checks the
// bound); a closed form keeps the size query exact without building the mesh.
uint64_t solver_capacity(uint32_t n, uint32_t nv) {
  const uint64_t npad = (uint64_t(nv) + 3) / 4 * 4;
  return npad * (uint64_t(21 * n) / 4 + 24);
}

void StepScratch::carve(Arena& a, const CubeSphere& m) {
  const size_t nv = m.nv;
  normals = a.alloc<double>(3 * nv);
  target = a.alloc<double>(3 * nv);
  disp = a.alloc<double>(3 * nv);
  tmp = a.alloc<double>(3 * nv);
  rhs = a.alloc<double>(3 * nv);
  weight = a.alloc<double>(nv);
  has = a.alloc<uint8_t>(nv);
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
  if (real2) scratch_.pattern.build(mesh_.nbr);
  if (!scratch_.solver.init(a, real2 ? scratch_.pattern.graph() : CsrGraph{mesh_.nv, nullptr, nullptr},
                            solver_capacity(mesh_.n, mesh_.nv)) &&
      real2)
    solver_failed_ = true;
  if (real2 && !solver_failed_) scratch_.program.build(mesh_, scratch_.solver);
  objects_ = a.alloc<Object>(cfg_.max_objects);
  Object probe;  // measuring pass: carve through a throw-away object
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    Object* o = objects_ ? new (&objects_[i]) Object() : &probe;
    o->x = a.alloc<double>(size_t(3) * mesh_.nv);
    o->roi.carve(a, cfg_.max_roi_voxels);
    o->model.carve(a, IntensityModel::kDefaultSamples);
  }
}

size_t Engine::workspace_bytes(const Config& c) {
  Arena a;
  a.alloc<Engine>(1);
  Engine probe;
  probe.cfg_ = c;
  probe.layout(a);
  return a.overflowed() ? 0 : a.used();
}

Engine* Engine::create(const Config& c, void* ws, size_t bytes) {
  Arena a(ws, bytes);
  void* at = a.alloc<Engine>(1);
  if (at == nullptr) return nullptr;
  Engine* e = new (at) Engine();
  e->cfg_ = c;
  e->layout(a);
  if (!a.ok() || e->solver_failed_) return nullptr;
  e->magic_ = kMagic;
  return e;
}

Err Engine::set_params(const Params& p) {
  const Err r = check_params(p, msg_, kMsgLen);
  if (r == Err::ok) {
    params_ = p;
    for (uint32_t i = 0; i < cfg_.max_objects; ++i) objects_[i].restart();  // new terms: move again
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
    objects_[i].restart();
  }
  return Err::ok;
}

Err Engine::sample(const double w[3], uint32_t mode, double* value) const {
  if (!vol_.valid()) return Err::misuse;
  if (!std::isfinite(w[0]) || !std::isfinite(w[1]) || !std::isfinite(w[2])) return Err::invalid_argument;
  if (mode == 0) *value = vol_.sample_nearest(w);
  else if (mode == 1) *value = vol_.sample_linear(w);
  else return Err::invalid_argument;
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
  const Err oe = check_object(object, false);
  if (oe != Err::ok) return oe;
  if (!vol_.valid()) {
    std::snprintf(msg_, kMsgLen, "init_sphere: no volume set (call ffseg_set_volume first)");
    return Err::misuse;
  }
  if (!std::isfinite(c[0]) || !std::isfinite(c[1]) || !std::isfinite(c[2])) {
    std::snprintf(msg_, kMsgLen, "init_sphere: centre must be finite");
    return Err::invalid_argument;
  }
  if (!(r > 0) || !std::isfinite(r)) {
    std::snprintf(msg_, kMsgLen, "init_sphere: radius %g mm must be positive and finite", r);
    return Err::invalid_argument;
  }
  if (!vol_.ball_meets_grid(c, r)) {
    std::snprintf(msg_, kMsgLen, "init_sphere: the sphere (%g, %g, %g) r = %g mm does not meet the volume",
                  c[0], c[1], c[2], r);
    return Err::sphere_outside;
  }
  Object& o = objects_[object];
  for (uint32_t v = 0; v < mesh_.nv; ++v)
    for (int d = 0; d < 3; ++d) o.x[3 * v + d] = c[d] + r * mesh_.unit[3 * v + d];
  for (int d = 0; d < 3; ++d) o.center[d] = c[d];
  o.radius = r;
  o.placed = true;
  o.polish = false;
  o.restart();
  o.roi.invalidate();
  o.model.reset();
  return Err::ok;
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

}  // namespace ffseg

// ---- one deformation step (thesis Algorithm 1) ---------------------------------

namespace ffseg {

namespace {

uint64_t now_us() {
  return uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::steady_clock::now().time_since_epoch())
                      .count());
}

// Weight floor for the positional term: thesis eq. 4.2.6 weights by d_i / d_mean,
// which would release a vertex that sits on its target; a floor keeps it held.
constexpr double kWeightFloor = 0.25;
// Every vertex is tied to its current position with this fraction of lambda_p,
// so that the system stays positive definite when no vertex has a target.
constexpr double kAnchor = 1e-3;
// Harmonic fill of the target-less gaps before diffusion: sweeps and the
// per-sweep change (mm) at which it stops.
constexpr uint32_t kFillSweeps = 200;
constexpr double kFillTolMm = 1e-3;

// Automatic diffusion rounds: 20 at n = 33, scaled with n^2 so that the
// displacement field is smoothed over the same share of the surface at every
// mesh resolution (a round spreads about one edge; edges shrink as 1/n).
// Measured on the cup: 20 rounds at n = 49 left the lid stuck (Dice 0.85),
// 44 reach 0.95-0.97; 8 at n = 21 do slightly better than 20.
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

// Rounds are always even (step_object rounds an odd count up). One round, eq. 4.2.2, is the mean over
// a vertex and its four neighbours: on the quad grid it maps the checkerboard
// mode (neighbours displaced in opposite senses) to -0.6 times itself, so an
// odd number of rounds turns the finest ripple of the displacement field
// against itself and the step feeds a sawtooth instead of damping it. At rest
// that grew without bound (sphere phantom, one polishing round: Dice 0.999 ->
// 0.983 over 140 steps; Colin27 meshes at n = 12, three rounds: half their
// edges bent by more than 11 degrees, the guard refusing creases every step).
// An even count makes every mode's factor (1 + lambda)^(2k) / 25^k >= 0.

uint32_t diffusion_rounds(uint32_t n) {
  const long r = std::lround(20.0 * (double(n) / 33.0) * (double(n) / 33.0));
  return r < 1 ? 1u : (r > 100 ? 100u : uint32_t(r));
}

// Converged: the mean displacement is below convergence_mm and, on binary
// targets, at most kMovingShare of the vertices still move by more than
// kStillFactor times it (a mean alone calls the cup converged while its cavity
// is still filling); while polishing, more than kPolishStillFactor times it
// (the cup's cavity corners fill a little each step: n = 21, alpha 0.3 stopped
// at Dice 0.963 with the first factor, reaches 0.97 with this one). Grey-level
// targets flicker between neighbouring voxel decisions: a few percent of the
// vertices keep moving by that much for good (Colin27 putamen: 11 more steps,
// none changing Dice by more than noise), so there the mean alone decides.
constexpr double kStillFactor = 4.0;
constexpr double kPolishStillFactor = 0.75;
constexpr double kMovingShare = 0.01;

bool still(const StepReport& r, uint32_t slot, uint32_t nv, double conv, bool binary) {
  return r.mean_displacement_mm[slot] < conv && (!binary || double(r.moving[slot]) <= kMovingShare * nv);
}

}  // namespace

Err Engine::step(StepReport* r) {
  if (!vol_.valid()) {
    std::snprintf(msg_, kMsgLen, "step: no volume set (call ffseg_set_volume first)");
    return Err::misuse;
  }
  *r = StepReport();
  uint32_t active = 0;
  bool all_converged = true;
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    if (!objects_[i].placed) continue;
    // A converged object stays where it is: it has reached the rest the
    // caller asked for, and further steps would only cost time.
    if (objects_[i].converged) {
      ++active;
      continue;
    }
    const Err e = step_object(i, r, active < kReportObjects ? active : kReportObjects);
    if (e != Err::ok) return e;
    // With binary targets, the first time an object comes to rest it goes on
    // polishing (see polish_rounds); it has converged when it comes to rest
    // again. Grey-level targets are noisy samples of the boundary: with little
    // smoothing the mesh follows the noise (right-hemisphere Colin27 mean Dice
    // 0.511 -> 0.492 when polishing), so they do not polish; at the first
    // rest they move their boundaries to the partial-volume level for a few
    // steps instead (Params::partial_volume_steps; with it from the first
    // step, the right-hemisphere Colin27 mean Dice fell 0.536 -> 0.501, the
    // thalamus leaking into the midbrain; after the first rest it rose to 0.550).
    Object& o = objects_[i];
    const bool polishes = params_.target_mode == TargetMode::binary;
    const bool rest = active < kReportObjects ? still(*r, active, mesh_.nv, params_.convergence_mm, polishes) : true;
    if (polishes) {
      if (!rest || !o.polish) all_converged = false;
      else o.converged = true;
      if (rest) o.polish = true;
    } else if (o.refining) {
      // Partial-volume boundaries (see Params::partial_volume_steps): done
      // when the object rests again or the steps are spent.
      if (rest || ++o.refine_steps >= params_.partial_volume_steps) o.converged = true;
      else all_converged = false;
    } else if (rest && params_.partial_volume_steps > 0) {
      o.refining = true;
      all_converged = false;
    } else if (rest) {
      o.converged = true;
    } else {
      all_converged = false;
    }
    ++active;
  }
  if (active == 0) {
    std::snprintf(msg_, kMsgLen, "step: no object placed (call ffseg_init_sphere first)");
    return Err::misuse;
  }
  ++steps_;
  r->step_index = steps_;
  r->active_objects = active;
  return all_converged ? Err::converged : Err::ok;
}

// Chapter 5 features: the smoothed crop around the mesh (recomputed only when
// the mesh outgrows it, with a search range of slack) and, once per sphere,
// the intensity model of the voxels inside it.
Err Engine::update_features(Object& o, StepReport* r) {
  const uint64_t t0 = now_us();
  const uint32_t nv = mesh_.nv;
  const double range = params_.range_mm();
  int64_t lo[3], hi[3];
  if (!o.model.valid())
    roi_box_for_ball(vol_, o.center, o.radius + range, lo, hi);
  else
    roi_box_for_points(vol_, o.x, nv, range, lo, hi);
  if (!o.roi.valid() || !o.roi.contains(lo, hi)) {
    if (o.model.valid()) roi_box_for_points(vol_, o.x, nv, 2 * range, lo, hi);
    SmoothingSettings sm;
    sm.iterations = params_.smoothing_iterations;
    sm.kappa = o.model.valid() ? o.kappa : params_.smoothing_kappa;
    // Once the model is fitted the box statistics are not read again: only the
    // first crop's (kept kappa, the model's variance floor) count.
    sm.statistics = !o.model.valid();
    const RoiStatus rs = o.roi.compute(vol_, lo, hi, sm, msg_, kMsgLen);
    if (rs == RoiStatus::too_large) return Err::roi_too_large;
    if (rs == RoiStatus::empty) {
      std::snprintf(msg_, kMsgLen, "step: the mesh has left the volume");
      return Err::sphere_outside;
    }
    if (rs != RoiStatus::ok) return Err::invalid_argument;
    o.kappa = o.roi.kappa();
  }
  if (!o.model.valid()) {
    IntensityModelSettings ms;
    ms.bin_radius = params_.bin_radius;
    ms.bin_separation = params_.bin_separation;
    ms.bin_min_count = params_.bin_min_count;
    ms.sigma_floor_fraction = params_.sigma_floor_fraction;
    LutSpec lut;
    lut.type = vol_.type();
    lut.slope = vol_.slope();
    lut.intercept = vol_.intercept();
    const ModelStatus ms_st = o.model.fit(o.roi, o.center, o.radius, ms, lut, msg_, kMsgLen);
    if (ms_st != ModelStatus::ok) return ms_st == ModelStatus::no_samples ? Err::sphere_outside : Err::invalid_argument;
  }
  r->stage_us[kStageFeatures] += now_us() - t0;
  return Err::ok;
}

Err Engine::step_object(uint32_t oi, StepReport* r, uint32_t slot) {
  Object& o = objects_[oi];
  StepScratch& s = scratch_;
  const uint32_t nv = mesh_.nv;
  double* x = o.x;
  uint64_t t0 = now_us(), t1;
  auto lap = [&](int stage) {
    t1 = now_us();
    r->stage_us[stage] += t1 - t0;
    t0 = t1;
  };

  // 1. Correspondences along the normals.
  vertex_normals(mesh_, x, s.normals);
  uint32_t found = 0;
  if (params_.target_mode == TargetMode::binary) {
    SearchSettings ss;
    ss.range_mm = params_.range_mm();
    ss.step_mm = params_.search_step_mm > 0 ? params_.search_step_mm : 0.5 * vol_.min_spacing();
    found = search_binary(vol_, nv, x, s.normals, ss, s.target, s.has);
  } else {
    const Err fe = update_features(o, r);
    if (fe != Err::ok) return fe;
    t0 = now_us();
    IntensitySearchSettings is;
    is.range_mm = params_.range_mm();
    is.step_mm = params_.search_step_mm;
    is.gamma = params_.intensity_gamma;
    is.consecutive_background = params_.consecutive_background;
    is.partial_volume = o.refining;
    found = search_intensity(o.roi, o.model, nv, x, s.normals, is, s.target, s.has);
  }
  lap(kStageSearch);

  // How far the vertices moved this step, and the report of it.
  double moved = 0;
  uint32_t moving = 0;
  auto tally = [&](double d2) {
    const double d = std::sqrt(d2);
    moved += d;
    moving += d > (o.polish ? kPolishStillFactor : kStillFactor) * params_.convergence_mm;
  };
  auto report = [&](uint32_t avoided, uint32_t folds) {
    if (slot >= kReportObjects) return;
    r->moving[slot] = moving;
    r->mean_displacement_mm[slot] = moved / nv;
    r->with_target[slot] = found;
    r->flips_avoided[slot] = avoided;
    r->folds_avoided[slot] = folds;
  };
  if (naive_) {
    for (uint32_t v = 0; v < nv; ++v) {
      if (!s.has[v]) continue;
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double dv = params_.step_size * (s.target[3 * size_t(v) + a] - x[3 * size_t(v) + a]);
        x[3 * size_t(v) + a] += dv;
        d2 += dv * dv;
      }
      tally(d2);
    }
    report(0, 0);
    return Err::ok;
  }

  // 2-3. Flip detection and avoidance on the contours.
  detect_flips(mesh_, x, s.target, s.has, params_.flip_tau, s.flipping);
  const uint32_t avoided = avoid_flips(mesh_, s.flipping, s.has, s.seq);
  lap(kStageFlips);

  // 4. Diffusion of the displacements.
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      s.disp[3 * size_t(v) + a] = s.has[v] ? s.target[3 * size_t(v) + a] - x[3 * size_t(v) + a] : 0.0;
  harmonic_fill(mesh_, s.disp, s.has, s.queue, kFillSweeps, kFillTolMm);
  uint32_t rounds = params_.diffusion_iterations ? params_.diffusion_iterations : diffusion_rounds(mesh_.n);
  if (o.polish) rounds = polish_rounds(rounds);
  rounds += rounds & 1;  // even (see diffusion_rounds)
  diffuse_displacements(mesh_, rounds, s.disp, s.has, s.tmp, s.tmp_has);
  lap(kStageDiffusion);

  // 5. Non-flipping self-intersections: shorten disagreeing displacements.
  const uint32_t folds = prevent_folds(mesh_, x, s.disp, s.has, params_.flip_tau, params_.step_size, s.folds);
  lap(kStageIntersection);

  // 6. Laplacian deformation: p_i = u_i + alpha d_i, weights d_i / d_mean.
  double dsum = 0;
  uint32_t dcount = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double p = x[3 * size_t(v) + a] + (s.has[v] ? params_.step_size * s.disp[3 * size_t(v) + a] : 0.0);
      s.target[3 * size_t(v) + a] = p;
      d2 += (p - x[3 * size_t(v) + a]) * (p - x[3 * size_t(v) + a]);
    }
    s.tmp[v] = std::sqrt(d2);
    if (s.has[v]) {
      dsum += s.tmp[v];
      ++dcount;
    }
  }
  const double dmean = dcount ? dsum / dcount : 0.0;
  const double lp = params_.lambda_position;
  for (uint32_t v = 0; v < nv; ++v) {
    double w = lp * kAnchor;
    if (s.has[v]) {
      const double rel = dmean > 0 ? s.tmp[v] / dmean : 1.0;
      w += lp * (rel > kWeightFloor ? rel : kWeightFloor);
    }
    s.weight[v] = w;
  }
  // With the storage program (always, on the cube-sphere) only the values
  // are computed here: the factorisation stores them group by group.
  const bool fused = s.program.ok;
  if (fused)
    laplacian_values(params_.lambda_laplacian, params_.lambda_uniform, s.weight, s.program);
  else
    assemble_laplacian(mesh_, params_.lambda_laplacian, params_.lambda_uniform, s.weight, s.solver, nullptr);
  // The anchor pulls towards u_i, the positional term towards p_i: one target
  // per vertex, the weighted mean of the two.
  for (uint32_t v = 0; v < nv; ++v) {
    if (!s.has[v]) continue;
    const double wa = lp * kAnchor, wp = s.weight[v] - wa;
    for (int a = 0; a < 3; ++a) {
      const size_t q = 3 * size_t(v) + a;
      s.target[q] = (wa * x[q] + wp * s.target[q]) / s.weight[v];
    }
  }
  laplacian_rhs(mesh_, params_.lambda_laplacian, params_.lambda_uniform, x, s.target, s.weight, s.rhs, s.tmp);
  lap(kStageAssembly);
  // The factorisation stores each row group's matrix entries, factors the
  // group and forward-substitutes the three right-hand sides in it while it
  // is in cache; the solve stage is the backward half.
  const int fr = fused ? s.solver.assign_factor_forward(s.program.off, s.program.val, s.program.count, s.rhs, nv)
                       : s.solver.factor_forward(s.rhs, nv);
  lap(kStageFactor);
  if (fr != EnvelopeCholesky::kOk) {
    std::snprintf(msg_, kMsgLen, "step: factorisation failed (code %d, row %lld); mesh unchanged", fr,
                  (long long)s.solver.failed_row());
    return Err::numeric;
  }
  s.solver.solve_forwarded(s.rhs, nv);
  lap(kStageSolve);
  for (size_t q = 0; q < size_t(3) * nv; ++q)
    if (!std::isfinite(s.rhs[q])) {
      std::snprintf(msg_, kMsgLen, "step: the solve produced non-finite positions; mesh unchanged");
      return Err::numeric;
    }
  guard_step(mesh_, x, s.rhs, s.tmp, s.weight, s.tmp_has, s.flipping, s.triangles);
  lap(kStageGuard);
  for (uint32_t v = 0; v < nv; ++v) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double nx = s.rhs[size_t(a) * nv + v];
      d2 += (nx - x[3 * size_t(v) + a]) * (nx - x[3 * size_t(v) + a]);
      x[3 * size_t(v) + a] = nx;
    }
    tally(d2);
  }
  report(avoided, folds);
  return Err::ok;
}

}  // namespace ffseg
