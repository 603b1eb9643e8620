#include "engine.h"

#include <cmath>
#include <cstdio>
#include <new>

#include "rasterize.h"

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
  else if (!in_open_closed(p.search_range_mm, 0, 1e4)) bad = "search_range_mm (0, 1e4]";
  else if (!in_range(p.search_step_mm, 0, 100)) bad = "search_step_mm [0, 100]";
  else if (!in_range(p.convergence_mm, 0, 100)) bad = "convergence_mm [0, 100]";
  else if (p.diffusion_iterations > 100) bad = "diffusion_iterations 0..100";
  else if (p.consecutive_background < 1 || p.consecutive_background > 64) bad = "consecutive_background 1..64";
  if (bad) {
    std::snprintf(msg, n, "params.%s: value out of range", bad);
    return Err::invalid_argument;
  }
  return Err::ok;
}

void Engine::layout(Arena& a) {
  mesh_.carve(a, cfg_.mesh_resolution);
  objects_ = a.alloc<Object>(cfg_.max_objects);
  for (uint32_t i = 0; i < cfg_.max_objects; ++i) {
    double* x = a.alloc<double>(size_t(3) * mesh_.nv);
    if (objects_) {
      new (&objects_[i]) Object();
      objects_[i].x = x;
    }
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
  if (!a.ok()) return nullptr;
  e->mesh_.build();
  e->magic_ = kMagic;
  return e;
}

Err Engine::set_params(const Params& p) {
  const Err r = check_params(p, msg_, kMsgLen);
  if (r == Err::ok) params_ = p;
  return r;
}

Err Engine::set_volume(const VolumeDesc& d) {
  VolumeView v;
  if (!v.assign(d, msg_, kMsgLen)) return Err::invalid_volume;
  vol_ = v;
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
  if (tris) triangulate(mesh_, tris);
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
