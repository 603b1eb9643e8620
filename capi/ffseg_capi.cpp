// The C ABI: the only place that knows public status codes and struct_size.
// Every entry point validates its pointers, copies versioned structs through
// min(struct_size, sizeof) and maps the core's Err onto ffseg_status.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "capi_internal.h"
#include "engine.h"
#include "ffseg.h"

using ffseg::Engine;
using ffseg::Err;

namespace {

// Messages of calls made without an engine, per thread (static storage, no allocation).
thread_local char t_msg[512];

void set_tmsg(const char* s) { std::snprintf(t_msg, sizeof t_msg, "%s", s); }

ffseg_status to_status(Err e) {
  switch (e) {
    case Err::ok: return FFSEG_OK;
    case Err::converged: return FFSEG_CONVERGED;
    case Err::degenerate: return FFSEG_DEGENERATE;
    case Err::invalid_argument: return FFSEG_ERR_INVALID_ARGUMENT;
    case Err::null_pointer: return FFSEG_ERR_NULL_POINTER;
    case Err::workspace_too_small: return FFSEG_ERR_WORKSPACE_TOO_SMALL;
    case Err::workspace_misaligned: return FFSEG_ERR_WORKSPACE_MISALIGNED;
    case Err::invalid_volume: return FFSEG_ERR_INVALID_VOLUME;
    case Err::object_out_of_range: return FFSEG_ERR_OBJECT_OUT_OF_RANGE;
    case Err::buffer_too_small: return FFSEG_ERR_BUFFER_TOO_SMALL;
    case Err::misuse: return FFSEG_ERR_MISUSE;
    case Err::numeric: return FFSEG_ERR_NUMERIC;
    case Err::roi_too_large: return FFSEG_ERR_ROI_TOO_LARGE;
    case Err::sphere_outside: return FFSEG_ERR_SPHERE_OUTSIDE;
    case Err::config_too_large: return FFSEG_ERR_CONFIG_TOO_LARGE;
    case Err::not_implemented: return FFSEG_ERR_NOT_IMPLEMENTED;
  }
  return FFSEG_ERR_INVALID_ARGUMENT;
}

// Copies a caller struct whose layout may be older (shorter) or newer (longer)
// than ours over `out`, which holds the defaults; fields the caller lacks keep them.
template <class T>
bool read_versioned(const T* in, size_t min_size, T* out) {
  const uint32_t sz = in->struct_size;
  if (sz < min_size) return false;
  std::memcpy(out, in, sz < sizeof(T) ? sz : sizeof(T));
  out->struct_size = sizeof(T);
  return true;
}

using ffseg::capi::Guard;
using ffseg::capi::kGuardBytes;
using ffseg::capi::kTailBytes;

Engine* impl(ffseg_engine* e) { return ffseg::capi::engine_of(e); }
const Engine* impl(const ffseg_engine* e) { return ffseg::capi::engine_of(const_cast<ffseg_engine*>(e)); }
Guard* guard_of(const ffseg_engine* e) { return reinterpret_cast<Guard*>(const_cast<ffseg_engine*>(e)); }

// The workspace's integrity (issue 20). A caller that writes into the
// workspace it handed over (a buffer overrun, a memset of the wrong block, a
// workspace copied elsewhere) must get MISUSE with a message instead of a call
// reading garbage pointers. The checks are cheap: the guard in front of the
// engine (a magic, and a canary hashed from the guard's own address and
// contents), a tail canary after the engine's last byte, the engine's own
// magic, and a hash of the layout table: every word of the Engine object that
// held an address inside the workspace when it was created (the arrays the
// layout carved; their positions are the guard's map; the table's addresses
// may be permuted among those words, not changed). Writes into the arrays
// themselves are not detected; that would cost a pass over the workspace.
constexpr uint64_t kGuardMagic = 0x66667365672d7773ull;  // "ffseg-ws"

uint64_t mix(uint64_t h, uint64_t v) {  // splitmix64 step over h ^ v
  uint64_t z = (h ^ v) + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Word w of the Engine object, words pointer-sized: an address is one word
// on every target (8-byte words glued a wasm32 pointer to its neighbour field,
// whose changes then read as a damaged layout table).
uint64_t word_at(const void* base, size_t w) {
  uintptr_t v;
  std::memcpy(&v, static_cast<const unsigned char*>(base) + sizeof v * w, sizeof v);
  return uint64_t(v);
}

// A sum, not a chain: the engine swaps ping-pong buffers (two words of the
// table exchange their addresses), which keeps the set of addresses and so the
// sum; a word overwritten with anything else changes it.
uint64_t layout_sum(const Guard& g, const Engine* en) {
  uint64_t h = 0;
  for (size_t m = 0; m < Guard::kMapWords; ++m)
    for (uint64_t bits = g.map[m]; bits != 0; bits &= bits - 1) {
      const size_t w = 64 * m + size_t(__builtin_ctzll(bits));
      h += mix(0x6c61796f7574ull, word_at(en, w));
    }
  return h;
}

uint64_t guard_canary(const Guard& g) {
  uint64_t h = mix(reinterpret_cast<uintptr_t>(&g), g.engine_bytes);
  h = mix(h, g.layout);
  for (size_t m = 0; m < Guard::kMapWords; ++m) h = mix(h, g.map[m]);
  return h;
}

unsigned char* tail_of(const Guard& g) {
  return reinterpret_cast<unsigned char*>(const_cast<Guard*>(&g)) + kGuardBytes + g.engine_bytes;
}

// Records the guard of a freshly created engine. measured: the engine's
// bytes as Engine::workspace_bytes measured them, where every word that holds
// an address into the workspace is null: a word is in the layout table when
// it is null there and an address inside the workspace here. The range alone
// took fields for addresses whenever their values fell in it: on wasm32, with
// a workspace near 1 GB, the high words of doubles such as 1.0 or 0.5 do,
// and the first later change of such a field read as a damaged workspace
// (eight objects at n = 33 on Colin27 in the browser).
void seal(Guard* g, const Engine* en, size_t engine_bytes, const unsigned char* measured) {
  const uintptr_t lo = reinterpret_cast<uintptr_t>(g);
  const uintptr_t hi = lo + kGuardBytes + engine_bytes;
  std::memset(g->map, 0, sizeof g->map);
  for (size_t w = 0; w < Guard::kEngineWords; ++w) {
    const uint64_t v = word_at(en, w);
    if (v >= lo && v < hi && word_at(measured, w) == 0) g->map[w / 64] |= uint64_t(1) << (w % 64);
  }
  g->engine_bytes = engine_bytes;
  g->layout = layout_sum(*g, en);
  g->canary = guard_canary(*g);
  std::memcpy(tail_of(*g), &g->canary, sizeof g->canary);
  g->magic = kGuardMagic;
}

// nullptr when e is a live, intact engine; otherwise why not (static text).
const char* damage(const ffseg_engine* e) {
  const Guard& g = *guard_of(e);
  if (g.magic != kGuardMagic) return "not a live ffseg engine";
  if (g.canary != guard_canary(g))
    return "workspace damaged: the guard in front of the engine was overwritten (the caller wrote into the workspace)";
  if (std::memcmp(tail_of(g), &g.canary, sizeof g.canary) != 0)
    return "workspace damaged: the canary after the engine was overwritten (the caller wrote into the workspace)";
  const Engine* en = impl(e);
  if (en->magic() != Engine::kMagic)
    return "workspace damaged: the engine's header was overwritten (the caller wrote into the workspace)";
  if (layout_sum(g, en) != g.layout)
    return "workspace damaged: the engine's layout table was overwritten (the caller wrote into the workspace)";
  return nullptr;
}

bool live(const ffseg_engine* e) { return e != nullptr && damage(e) == nullptr; }

// The size the public API asks for: guard + engine + tail, 0 on overflow.
size_t total_bytes(size_t engine_bytes) {
  if (engine_bytes == 0 || engine_bytes > SIZE_MAX - kGuardBytes - kTailBytes) return 0;
  return kGuardBytes + engine_bytes + kTailBytes;
}

// The first released ffseg_config (0.1) ended after max_roi_voxels; such a
// caller gets target_mode's default, intensity allowed, as before.
const size_t kConfigV1Size = offsetof(ffseg_config, target_mode);

// Converts the public config; returns an error status or OK.
ffseg_status convert_config(const ffseg_config* c, ffseg::Config* out, char* msg, size_t n) {
  if (c == nullptr) {
    std::snprintf(msg, n, "config is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  ffseg_config full;
  ffseg_config_init_default(&full);
  if (!read_versioned(c, kConfigV1Size, &full)) {
    std::snprintf(msg, n, "config.struct_size = %u is smaller than %zu", c->struct_size, kConfigV1Size);
    return FFSEG_ERR_STRUCT_SIZE;
  }
  if (full.reserved0 != 0 || full.reserved1 != 0) {
    std::snprintf(msg, n, "config.%s must be 0", full.reserved0 != 0 ? "reserved0" : "reserved1");
    return FFSEG_ERR_INVALID_ARGUMENT;
  }
  if (full.target_mode != FFSEG_TARGET_BINARY && full.target_mode != FFSEG_TARGET_INTENSITY) {
    std::snprintf(msg, n, "config.target_mode = %u is neither FFSEG_TARGET_BINARY (0) nor FFSEG_TARGET_INTENSITY (1)",
                  full.target_mode);
    return FFSEG_ERR_INVALID_ARGUMENT;
  }
  out->max_objects = full.max_objects;
  out->mesh_resolution = full.mesh_resolution;
  out->max_roi_voxels = full.max_roi_voxels;
  out->max_region_voxels = full.max_region_voxels;
  out->target_mode = ffseg::TargetMode(full.target_mode);
  return to_status(ffseg::check_config(*out, msg, n));
}

}  // namespace

struct ffseg_engine {};

// opaque: the pointer is the ffseg::Engine in the workspace

// The first released ffseg_params layout ended after consecutive_background.
static const size_t kParamsV1Size = offsetof(ffseg_params, consecutive_background) + sizeof(uint32_t);

// Every table field exists in ffseg_params with the table's kind (the
// field-by-field order and offsets are checked by tests/engine/test_params.cpp).
#define FFSEG_PARAM_KIND(name, ctype, kind, def, lo, hi, bounds, unit, doc)                              \
  static_assert(sizeof(ffseg_params::name) == (ffseg::ParamKind::kind == ffseg::ParamKind::U32 ? 4 : 8), \
                #name ": ffseg_params and param_table.h disagree on the type");
FFSEG_PARAM_TABLE(FFSEG_PARAM_KIND)
#undef FFSEG_PARAM_KIND

extern "C" {

FFSEG_API uint32_t ffseg_version_number(void) { return FFSEG_VERSION_NUMBER; }

FFSEG_API const char* ffseg_status_string(ffseg_status s) {
  switch (s) {
    case FFSEG_OK: return "ok";
    case FFSEG_CONVERGED: return "converged";
    case FFSEG_DEGENERATE: return "at rest, but some object is no segmentation (ffseg_step_info.object_flags)";
    case FFSEG_ERR_INVALID_ARGUMENT: return "invalid argument";
    case FFSEG_ERR_NULL_POINTER: return "null pointer";
    case FFSEG_ERR_WORKSPACE_TOO_SMALL: return "workspace too small";
    case FFSEG_ERR_WORKSPACE_MISALIGNED: return "workspace not 64-byte aligned";
    case FFSEG_ERR_INVALID_VOLUME: return "invalid volume";
    case FFSEG_ERR_OBJECT_OUT_OF_RANGE: return "object index out of range";
    case FFSEG_ERR_BUFFER_TOO_SMALL: return "buffer too small";
    case FFSEG_ERR_MISUSE: return "call made in the wrong order";
    case FFSEG_ERR_NUMERIC: return "numeric failure";
    case FFSEG_ERR_ROI_TOO_LARGE: return "region of interest exceeds max_roi_voxels or max_region_voxels";
    case FFSEG_ERR_SPHERE_OUTSIDE: return "sphere does not meet the volume";
    case FFSEG_ERR_STRUCT_SIZE: return "struct_size too small";
    case FFSEG_ERR_CONFIG_TOO_LARGE: return "configuration too large";
    case FFSEG_ERR_NOT_IMPLEMENTED: return "not implemented";
    default: return "unknown status";
  }
}

FFSEG_API const char* ffseg_last_error(const ffseg_engine* e) {
  if (e == nullptr) return t_msg;
  if (const char* why = damage(e)) return why;
  return impl(e)->message();
}

FFSEG_API void ffseg_config_init_default(ffseg_config* c) {
  if (c == nullptr) return;
  const ffseg::Config d;
  std::memset(c, 0, sizeof *c);
  c->struct_size = sizeof(ffseg_config);
  c->max_objects = d.max_objects;
  c->mesh_resolution = d.mesh_resolution;
  c->max_roi_voxels = d.max_roi_voxels;
  c->max_region_voxels = d.max_region_voxels;
  c->target_mode = uint32_t(d.target_mode);
}

FFSEG_API ffseg_status ffseg_workspace_size(const ffseg_config* c, size_t* bytes) {
  t_msg[0] = '\0';
  if (bytes == nullptr) {
    set_tmsg("workspace_size: bytes is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  *bytes = 0;
  ffseg::Config cfg;
  const ffseg_status st = convert_config(c, &cfg, t_msg, sizeof t_msg);
  if (st != FFSEG_OK) return st;
  const size_t n = total_bytes(Engine::workspace_bytes(cfg));
  if (n == 0) {
    set_tmsg("workspace_size: the configuration needs more memory than size_t can address");
    return FFSEG_ERR_CONFIG_TOO_LARGE;
  }
  *bytes = n;
  return FFSEG_OK;
}

FFSEG_API ffseg_status ffseg_create(const ffseg_config* c, void* workspace, size_t bytes,
                                    ffseg_engine** out) {
  t_msg[0] = '\0';
  if (out == nullptr) {
    set_tmsg("create: out is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  *out = nullptr;
  ffseg::Config cfg;
  const ffseg_status st = convert_config(c, &cfg, t_msg, sizeof t_msg);
  if (st != FFSEG_OK) return st;
  if (workspace == nullptr) {
    set_tmsg("create: workspace is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  if (reinterpret_cast<uintptr_t>(workspace) % ffseg::kAlign != 0) {
    set_tmsg("create: workspace must be 64-byte aligned");
    return FFSEG_ERR_WORKSPACE_MISALIGNED;
  }
  alignas(Engine) unsigned char measured[sizeof(Engine)];
  const size_t engine_need = Engine::workspace_bytes(cfg, measured);
  const size_t need = total_bytes(engine_need);
  if (need == 0) {
    set_tmsg("create: the configuration needs more memory than size_t can address");
    return FFSEG_ERR_CONFIG_TOO_LARGE;
  }
  if (bytes < need) {
    std::snprintf(t_msg, sizeof t_msg, "create: workspace has %zu bytes, needs %zu", bytes, need);
    return FFSEG_ERR_WORKSPACE_TOO_SMALL;
  }
  // A destroyed engine's guard must not pass for live while the new one is built.
  Guard* g = static_cast<Guard*>(workspace);
  g->magic = 0;
  Engine* e = Engine::create(cfg, static_cast<unsigned char*>(workspace) + kGuardBytes, engine_need);
  if (e == nullptr) {
    std::snprintf(t_msg, sizeof t_msg, "create: workspace has %zu bytes, needs %zu", bytes, need);
    return FFSEG_ERR_WORKSPACE_TOO_SMALL;
  }
  seal(g, e, engine_need, measured);
  *out = reinterpret_cast<ffseg_engine*>(g);
  return FFSEG_OK;
}

FFSEG_API void ffseg_destroy(ffseg_engine* e) {
  // A damaged engine is retired too: its guard says so, whatever the rest holds.
  if (e == nullptr || guard_of(e)->magic != kGuardMagic) return;
  guard_of(e)->magic = 0;
  if (impl(e)->magic() == Engine::kMagic) impl(e)->retire();
}

FFSEG_API void ffseg_params_init_default(ffseg_params* p) {
  if (p == nullptr) return;
  const ffseg::Params d;
  std::memset(p, 0, sizeof *p);
  p->struct_size = sizeof(ffseg_params);
#define FFSEG_PARAM_OUT(name, ctype, kind, def, lo, hi, bounds, unit, doc) p->name = decltype(p->name)(d.name);
  FFSEG_PARAM_TABLE(FFSEG_PARAM_OUT)
#undef FFSEG_PARAM_OUT
}

#define FFSEG_REQUIRE_ENGINE(e)                                   \
  do {                                                            \
    if ((e) == nullptr) return FFSEG_ERR_NULL_POINTER;            \
    if (!live(e)) return FFSEG_ERR_MISUSE;                        \
  } while (0)

static ffseg_status set_params_call(ffseg_engine* e, const ffseg_params* p) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = impl(e);
  en->clear_message();
  if (p == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "set_params: params is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  ffseg_params full;
  ffseg_params_init_default(&full);
  if (!read_versioned(p, kParamsV1Size, &full)) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "params.struct_size = %u is smaller than %zu",
                  p->struct_size, sizeof(ffseg_params));
    return FFSEG_ERR_STRUCT_SIZE;
  }
  // Refused now so that a later version may give the field a meaning with 0 as its default.
  if (full.reserved1 != 0) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "params.reserved1 must be 0");
    return FFSEG_ERR_INVALID_ARGUMENT;
  }
  ffseg::Params q;
#define FFSEG_PARAM_IN(name, ctype, kind, def, lo, hi, bounds, unit, doc) q.name = decltype(q.name)(full.name);
  FFSEG_PARAM_TABLE(FFSEG_PARAM_IN)
#undef FFSEG_PARAM_IN
  return to_status(en->set_params(q));
}

static ffseg_status set_volume_call(ffseg_engine* e, const ffseg_volume* v) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = impl(e);
  en->clear_message();
  if (v == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "set_volume: volume is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  ffseg_volume full;
  std::memset(&full, 0, sizeof full);
  if (!read_versioned(v, sizeof(ffseg_volume), &full)) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "volume.struct_size = %u is smaller than %zu",
                  v->struct_size, sizeof(ffseg_volume));
    return FFSEG_ERR_STRUCT_SIZE;
  }
  ffseg::VolumeDesc d;
  d.type = full.voxel_type;
  d.data = full.data;
  d.data_bytes = full.data_bytes;
  d.offset = full.offset;
  for (int a = 0; a < 3; ++a) {
    d.dims[a] = full.dims[a];
    d.strides[a] = full.strides[a];
  }
  for (int q = 0; q < 16; ++q) d.index_to_world[q] = full.index_to_world[q];
  d.slope = full.rescale_slope;
  d.intercept = full.rescale_intercept;
  return to_status(en->set_volume(d));
}

static ffseg_status sample_call(const ffseg_engine* e, const double point_mm[3], uint32_t mode,
                                    double* value) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = const_cast<Engine*>(impl(e));
  en->clear_message();
  if (point_mm == nullptr || value == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "sample: %s is NULL", point_mm ? "value" : "point");
    return FFSEG_ERR_NULL_POINTER;
  }
  return to_status(en->sample(point_mm, mode, value));
}

static ffseg_status init_mesh_call(ffseg_engine* e, uint32_t object, const double center_mm[3], double radius_mm,
                                   const float* xyz, size_t n_vertices) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = impl(e);
  en->clear_message();
  if (center_mm == nullptr || xyz == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "init_mesh: %s is NULL", center_mm ? "xyz" : "center");
    return FFSEG_ERR_NULL_POINTER;
  }
  // n_vertices = 6 n^2: the resolution it names.
  const double nd = std::sqrt(double(n_vertices) / 6.0);
  const uint64_t n = uint64_t(nd + 0.5);
  if (n < 2 || n > 1024 || 6 * n * n != n_vertices) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen,
                  "init_mesh: n_vertices = %zu is not 6 n^2 for a mesh resolution n in 2..1024", n_vertices);
    return FFSEG_ERR_INVALID_ARGUMENT;
  }
  return to_status(en->init_mesh(object, center_mm, radius_mm, xyz, uint32_t(n)));
}

static ffseg_status init_sphere_call(ffseg_engine* e, uint32_t object, const double center_mm[3],
                                         double radius_mm) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = impl(e);
  en->clear_message();
  if (center_mm == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "init_sphere: center is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  // Meshes leave the engine as float: a finite sphere whose vertices would not
  // fit (|centre| + radius beyond 1e30 mm) would come back as infinities.
  if (object < en->config().max_objects && en->volume().valid()) {
    constexpr double kMaxCoordMm = 1e30;
    for (int a = 0; a < 3; ++a) {
      const double reach = std::fabs(center_mm[a]) + std::fabs(radius_mm);
      if (reach > kMaxCoordMm && std::isfinite(reach)) {
        std::snprintf(en->message_buffer(), Engine::kMsgLen,
                      "init_sphere: |centre| + radius = %g mm exceeds 1e30 mm (meshes are extracted as float)",
                      reach);
        return FFSEG_ERR_INVALID_ARGUMENT;
      }
    }
  }
  return to_status(en->init_sphere(object, center_mm, radius_mm));
}

// Callers built against 0.3 pass an ffseg_step_info that ends after
// stage_us; they get the fields they know, and the bytes past them are theirs.
static const size_t kStepInfoFirstSize = offsetof(ffseg_step_info, object_flags);
static const size_t kStepInfoV04Size = offsetof(ffseg_step_info, guard_held);
static const size_t kStepInfoV05Size = offsetof(ffseg_step_info, respaced);
static_assert(FFSEG_OBJECT_NO_BOUNDARY == ffseg::kObjectNoBoundary && FFSEG_OBJECT_FILLS_GRID == ffseg::kObjectFillsGrid &&
                  FFSEG_OBJECT_STALLED == ffseg::kObjectStalled,
              "object flags");

static ffseg_status step_call(ffseg_engine* e, ffseg_step_info* info) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = impl(e);
  en->clear_message();
  if (info != nullptr && info->struct_size < kStepInfoFirstSize) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "step_info.struct_size = %u is smaller than %zu",
                  info->struct_size, kStepInfoFirstSize);
    return FFSEG_ERR_STRUCT_SIZE;
  }
  ffseg::StepReport r;
  const Err st = en->step(&r);
  if (info != nullptr && (st == Err::ok || st == Err::converged || st == Err::degenerate)) {
    static_assert(ffseg::kReportObjects == FFSEG_REPORT_OBJECTS, "report sizes");
    static_assert(ffseg::kStageCount == FFSEG_STAGE_COUNT, "stage counts");
    info->step_index = r.step_index;
    info->active_objects = r.active_objects;
    info->reserved0 = 0;
    for (uint32_t i = 0; i < FFSEG_REPORT_OBJECTS; ++i) {
      info->mean_displacement_mm[i] = r.mean_displacement_mm[i];
      info->vertices_with_target[i] = r.with_target[i];
      info->flips_avoided[i] = r.flips_avoided[i];
      info->intersections_avoided[i] = r.folds_avoided[i];
      info->border_vertices[i] = r.border_vertices[i];
    }
    for (int s = 0; s < FFSEG_STAGE_COUNT; ++s) info->stage_us[s] = r.stage_us[s];
    if (info->struct_size >= kStepInfoV04Size) {
      for (uint32_t i = 0; i < FFSEG_REPORT_OBJECTS; ++i) info->object_flags[i] = r.object_flags[i];
      info->flags_all = r.flags_all;
      info->reserved1 = 0;
    }
    if (info->struct_size >= kStepInfoV05Size)
      for (uint32_t i = 0; i < FFSEG_REPORT_OBJECTS; ++i) {
        info->guard_held[i] = r.guard_held[i];
        info->far_outward[i] = r.far_outward[i];
        info->far_inward[i] = r.far_inward[i];
      }
    if (info->struct_size >= sizeof(ffseg_step_info))
      for (uint32_t i = 0; i < FFSEG_REPORT_OBJECTS; ++i) info->respaced[i] = r.respaced[i];
  }
  return to_status(st);
}

static ffseg_status extract_mesh_call(const ffseg_engine* e, uint32_t object, float* xyz,
                                          size_t xyz_capacity, uint32_t* tris, size_t tri_capacity,
                                          size_t* n_vertices, size_t* n_tris) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = const_cast<Engine*>(impl(e));
  en->clear_message();
  return to_status(en->extract_mesh(object, xyz, xyz_capacity, tris, tri_capacity, n_vertices, n_tris));
}

static ffseg_status rasterize_call(const ffseg_engine* e, uint32_t object, uint8_t* mask,
                                       const int64_t strides[3]) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = const_cast<Engine*>(impl(e));
  en->clear_message();
  if (mask == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "rasterize: mask is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  if (!en->volume().valid()) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "rasterize: no volume set");
    return FFSEG_ERR_MISUSE;
  }
  return to_status(en->rasterize(object, mask, strides));
}

static ffseg_status region_mask_call(const ffseg_engine* e, uint32_t object, uint8_t* mask,
                                     const int64_t strides[3]) {
  FFSEG_REQUIRE_ENGINE(e);
  Engine* en = const_cast<Engine*>(impl(e));
  en->clear_message();
  if (mask == nullptr) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "region_mask: mask is NULL");
    return FFSEG_ERR_NULL_POINTER;
  }
  if (!en->volume().valid()) {
    std::snprintf(en->message_buffer(), Engine::kMsgLen, "region_mask: no volume set");
    return FFSEG_ERR_MISUSE;
  }
  return to_status(en->region_mask(object, mask, strides));
}

// Every failing call leaves a message: the engine's own, else one naming the
// call and the status; and a copy in the thread's slot, so that
// ffseg_last_error(NULL) always tells the thread's latest failure, never an
// older, unrelated one.
static ffseg_status finish(const char* call, const ffseg_engine* e, ffseg_status s) {
  if (s >= 0) return s;
  if (e == nullptr) {
    std::snprintf(t_msg, sizeof t_msg, "%s: engine is NULL", call);
  } else if (guard_of(e)->magic != kGuardMagic) {
    std::snprintf(t_msg, sizeof t_msg, "%s: not a live engine (destroyed, or not made by ffseg_create)", call);
  } else if (const char* why = damage(e)) {
    std::snprintf(t_msg, sizeof t_msg, "%s: %s", call, why);
  } else {
    Engine* en = const_cast<Engine*>(impl(e));
    if (en->message()[0] == '\0')
      std::snprintf(en->message_buffer(), Engine::kMsgLen, "%s: %s", call, ffseg_status_string(s));
    set_tmsg(en->message());
  }
  return s;
}

FFSEG_API ffseg_status ffseg_set_params(ffseg_engine* e, const ffseg_params* p) {
  return finish("set_params", e, set_params_call(e, p));
}

FFSEG_API ffseg_status ffseg_set_volume(ffseg_engine* e, const ffseg_volume* v) {
  return finish("set_volume", e, set_volume_call(e, v));
}

FFSEG_API ffseg_status ffseg_sample(const ffseg_engine* e, const double point_mm[3], uint32_t mode,
                                    double* value) {
  return finish("sample", e, sample_call(e, point_mm, mode, value));
}

FFSEG_API ffseg_status ffseg_init_sphere(ffseg_engine* e, uint32_t object, const double center_mm[3],
                                         double radius_mm) {
  return finish("init_sphere", e, init_sphere_call(e, object, center_mm, radius_mm));
}

FFSEG_API ffseg_status ffseg_init_mesh(ffseg_engine* e, uint32_t object, const double center_mm[3], double radius_mm,
                                       const float* xyz, size_t n_vertices) {
  return finish("init_mesh", e, init_mesh_call(e, object, center_mm, radius_mm, xyz, n_vertices));
}

FFSEG_API ffseg_status ffseg_step(ffseg_engine* e, ffseg_step_info* info) {
  return finish("step", e, step_call(e, info));
}

FFSEG_API ffseg_status ffseg_extract_mesh(const ffseg_engine* e, uint32_t object, float* xyz,
                                          size_t xyz_capacity, uint32_t* tris, size_t tri_capacity,
                                          size_t* n_vertices, size_t* n_tris) {
  return finish("extract_mesh", e, extract_mesh_call(e, object, xyz, xyz_capacity, tris, tri_capacity, n_vertices, n_tris));
}

FFSEG_API ffseg_status ffseg_rasterize(const ffseg_engine* e, uint32_t object, uint8_t* mask,
                                       const int64_t strides[3]) {
  return finish("rasterize", e, rasterize_call(e, object, mask, strides));
}

FFSEG_API ffseg_status ffseg_region_mask(const ffseg_engine* e, uint32_t object, uint8_t* mask,
                                         const int64_t strides[3]) {
  return finish("region_mask", e, region_mask_call(e, object, mask, strides));
}

}  // extern "C"
