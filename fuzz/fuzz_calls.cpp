// libFuzzer target "calls": a random sequence of C API calls on one engine.
//
// Input: a config block (max_objects, mesh_resolution, max_roi_voxels,
// max_region_voxels (0.6.0: regions on cells of several voxels, or refused),
// target_mode (binary-only or not), reserved fields, and the workspace size
// and alignment offered to ffseg_create, all allowed to be wrong), then one
// operation per byte group until the input ends: set_params with extreme or
// non-finite fields, set_volume with good or corrupted descriptors,
// init_sphere, step, extract_mesh into short or exact buffers, rasterize or
// region_mask (several objects' bounding regions), sample, destroy and
// re-create, status/message queries. Object indices come
// from the input and are often out of range.
//
// Every call must return a documented status; every refusal must leave the
// engine usable: after the sequence a clean segmentation still works (params
// reset, volume set, sphere placed, a step, a full extraction).
//
// Work per input is bounded so that the target runs at a thousand inputs per
// second under ASan and UBSan. A step is what costs (the first one of an
// engine most: the patch certificate is built lazily), so each object stepped
// takes n^2 from kWorkBudget, the final check's step included; a step that
// would exceed it is skipped (the final check then verifies everything but
// the step); besides, one step of two objects at n = 2 per input is free of
// the budget, so that the bounding regions (thesis 6.2) are computed and
// region_mask has something to read. Placements (an intensity fit and a
// contact test each) and iteration counts in the parameters are bounded too.
// The config block gives meshes of n <= 4 and up to 4 objects; a
// raw config asking for objects * n^2 > kCreateBudget is created only where
// creation must fail, and the small fallback engine runs the sequence (its six
// configs are created once and restored, fuzz_workspace.h; the input's own
// config is created by ffseg_create every time). So one object at n = 2 steps
// once per input, in the sequence or in the final check: with ASan and UBSan
// an engine's first step at n = 2 costs about 0.5 ms of CPU, more than all the
// rest of an input. Larger and multi-object steps are fuzz_volume's (n <= 4)
// and the unit tests' part; every call and every refusal stays reachable.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "ffseg.h"
#include "fuzz_reader.h"
#include "fuzz_workspace.h"

namespace {

using ffseg_fuzz::Reader;

// n^2 per object stepped (a step's cost grows with its 6 n^2 vertices).
constexpr uint64_t kWorkBudget = 4;
// objects * n^2 of the largest engine created (the config block's 4 x 4^2).
constexpr uint64_t kCreateBudget = 64;
// Steps of two objects at n = 2 (the regions stage) per input, beyond
// kWorkBudget; three and four objects are fuzz_volume's (their step guard
// tests every triangle against the others': four times the two's cost).
constexpr int kMaxRegionSteps = 1;
// init_sphere calls with a volume set per input.
constexpr int kMaxPlacements = 8;
// Destroy-and-re-create operations per input.
constexpr int kMaxRecreate = 1;
// Inputs taking the final check's step: those whose hash is 0 modulo this.
constexpr uint32_t kFinalStepShare = 2;

[[noreturn]] void finding(const char* what, long long st) {
  std::fprintf(stderr, "fuzz_calls: %s (%lld)\n", what, st);
  std::abort();
}

void check_status(ffseg_status st, const char* what) {
  if (st < FFSEG_ERR_NOT_IMPLEMENTED || st > FFSEG_DEGENERATE) finding(what, st);
  if (std::strcmp(ffseg_status_string(st), "unknown status") == 0) finding(what, st);
}

// Doubles a careless or hostile caller passes.
double pick_double(Reader& in) {
  static const double table[] = {0.0, -0.0, 1.0, 0.5, 0.25, 1e-300, -1e-300, 5e-324, 1e300, -1e300, 1e6,
                                 1e6 + 1, 1e4, 100.0, 100.5, 0.999999, 1.0000001, -1.0, 20.0, 3.0,
                                 NAN, -NAN, INFINITY, -INFINITY, 1e-9, 64.0, 1e-3, 2.0};
  const uint8_t s = in.take<uint8_t>();
  const size_t nt = sizeof table / sizeof table[0];
  if (s < nt) return table[s];
  if (s < 200) return (s - nt) * 0.125;
  return in.take<double>();
}

// Iteration counts (diffusion, smoothing, partial-volume steps): each round
// costs a pass over the mesh or the crop, so the valid range is explored at
// its small end and around its largest valid value only; out-of-range values
// still come.
uint32_t pick_count(Reader& in, uint32_t largest) {
  const uint8_t s = in.take<uint8_t>();
  if (s < 200) return s % 8;
  if (s < 250) return largest - 1 + s % 3;
  return in.take<uint32_t>();
}

uint32_t pick_u32(Reader& in) {
  const uint8_t s = in.take<uint8_t>();
  if (s < 128) return s % 70;
  if (s < 192) return uint32_t(s) << 24;
  if (s < 250) return 0xFFFFFFFFu - (s & 3);
  return in.take<uint32_t>();
}

// A 16^3 binary ball (u8), the same as f32, and a padded i16 copy with a
// flipped k axis: the good volumes the sequence can switch between.
struct Phantoms {
  static constexpr int N = 16;
  std::vector<uint8_t> u8;
  std::vector<float> f32;
  std::vector<int16_t> i16;  // rows padded to N + 3, k reversed
  Phantoms() : u8(N * N * N), f32(N * N * N), i16(size_t(N + 3) * N * N) {
    for (int k = 0; k < N; ++k)
      for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i) {
          const double d2 = (i - 7.5) * (i - 7.5) + (j - 7.0) * (j - 7.0) + (k - 8.0) * (k - 8.0);
          const uint8_t in = d2 < 25.0 ? 1 : 0;
          u8[size_t(i + N * (j + N * k))] = in;
          f32[size_t(i + N * (j + N * k))] = in ? 100.0f : -5.0f;
          i16[size_t(i + (N + 3) * (j + N * (N - 1 - k)))] = in ? 300 : 0;
        }
  }
  ffseg_volume volume(int which) const {
    ffseg_volume v;
    std::memset(&v, 0, sizeof v);
    v.struct_size = sizeof v;
    for (int a = 0; a < 3; ++a) v.dims[a] = N;
    const double A[16] = {1.5, 0, 0, -10, 0, 1.5, 0, 4, 0, 0, 2, 1, 0, 0, 0, 1};
    std::memcpy(v.index_to_world, A, sizeof A);
    v.rescale_slope = 1;
    switch (which % 3) {
      case 0:
        v.voxel_type = FFSEG_U8;
        v.data = u8.data();
        v.data_bytes = u8.size();
        v.strides[0] = 1; v.strides[1] = N; v.strides[2] = N * N;
        break;
      case 1:
        v.voxel_type = FFSEG_F32;
        v.data = f32.data();
        v.data_bytes = f32.size() * 4;
        v.strides[0] = 4; v.strides[1] = 4 * N; v.strides[2] = 4 * N * N;
        v.rescale_slope = 0.01;
        v.rescale_intercept = 0.05;
        break;
      default:
        v.voxel_type = FFSEG_I16;
        v.data = i16.data();
        v.data_bytes = i16.size() * 2;
        v.strides[0] = 2; v.strides[1] = 2 * (N + 3); v.strides[2] = -2 * (N + 3) * N;
        v.offset = 2 * int64_t(N + 3) * N * (N - 1);
        break;
    }
    return v;
  }
};

const Phantoms& phantoms() {
  static const Phantoms p;
  return p;
}


ffseg_config valid_config(uint32_t objects, uint32_t n) {
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.max_objects = objects;
  c.mesh_resolution = n;
  c.max_roi_voxels = int64_t(1) << 16;
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Reader in{data, size};
  const Phantoms& ph = phantoms();

  // ---- creation with a possibly odd config and workspace ---------------------
  ffseg_config cfg;
  ffseg_config_init_default(&cfg);
  const uint8_t cflags = in.take<uint8_t>();
  cfg.max_objects = (cflags & 1) ? pick_u32(in) : 1 + in.take<uint8_t>() % 4;
  cfg.mesh_resolution = (cflags & 2) ? pick_u32(in) : 2 + in.take<uint8_t>() % 3;
  // max_region_voxels out of range, with nothing else in the config that
  // workspace_size refuses first or that hides the field.
  bool region_refused = false;
  if (cflags & 4) {
    cfg.max_roi_voxels = in.take<int64_t>();
  } else {
    // bit7: a binary-only engine; (roi & 127) % 12 the crop budget's power of
    // two; (roi & 127) / 12 the region budget (0.6.0), mostly the default 0
    // (= max_roi_voxels), else so small that two objects' regions are marched
    // on cells (or refused as ROI_TOO_LARGE at the step), or out of range.
    const uint8_t roi = in.take<uint8_t>();
    cfg.max_roi_voxels = int64_t(1) << (8 + (roi & 127) % 12);
    static const int64_t regions[] = {0, 0, 0, 0, 0, 1, 64, 256, 4096, -1, (int64_t(1) << 40) + 1};
    cfg.max_region_voxels = regions[(roi & 127) / 12];
    region_refused = cfg.max_region_voxels < 0 || cfg.max_region_voxels > (int64_t(1) << 40);
    if (roi & 128) cfg.target_mode = FFSEG_TARGET_BINARY;
  }
  if (cflags & 8) cfg.struct_size = in.take<uint8_t>();
  if (cflags & 16) {  // a field that must be refused (unless struct_size hides it)
    const uint8_t bad = in.take<uint8_t>();
    if (bad % 3 == 0) cfg.reserved0 = 1;
    else if (bad % 3 == 1) cfg.reserved1 = 1;
    else cfg.target_mode = pick_u32(in) | 2;
  }
  const int64_t size_delta = int64_t(in.take<int8_t>()) * ((cflags & 32) ? 4096 : 1);
  const size_t misalign = (cflags & 64) ? 1 + in.take<uint8_t>() % 63 : 0;

  size_t need = 0;
  const ffseg_status ws_st = ffseg_workspace_size(&cfg, &need);
  check_status(ws_st, "workspace_size");
  if (region_refused && !(cflags & (1 | 2 | 8 | 16)) &&
      (ws_st != FFSEG_ERR_INVALID_ARGUMENT || !std::strstr(ffseg_last_error(nullptr), "max_region_voxels")))
    finding("workspace_size: max_region_voxels out of range not refused by name", ws_st);
  // An exact block (ASan poisons everything around it, fuzz_workspace.h).
  static ffseg_fuzz::ReusedBlock ws;
  ffseg_engine* e = reinterpret_cast<ffseg_engine*>(&ws);  // must be overwritten
  int64_t offered = int64_t(need) + size_delta;
  if (offered < 0) offered = 0;
  const bool would_succeed = misalign == 0 && offered >= int64_t(need);
  const uint64_t engine_cost = uint64_t(cfg.max_objects) * cfg.mesh_resolution * cfg.mesh_resolution;
  if (ws_st == FFSEG_OK) {
    if (need > (size_t(4) << 20) || (would_succeed && engine_cost > kCreateBudget)) {
      // Too big to run here; creation is exercised with the fallback below.
      e = nullptr;
    } else {
      unsigned char* mem = ws.get(size_t(offered), misalign);
      const ffseg_status st = ffseg_create(&cfg, mem, size_t(offered), &e);
      check_status(st, "create");
      const bool should = would_succeed;
      if ((st == FFSEG_OK) != should) finding("create: success does not match size/alignment", st);
      if (st != FFSEG_OK && e != nullptr) finding("create failed but *out is not NULL", st);
      if (st == FFSEG_ERR_WORKSPACE_TOO_SMALL && ffseg_last_error(nullptr)[0] == '\0')
        finding("WORKSPACE_TOO_SMALL without a message", st);
    }
  } else {
    if (need != 0) finding("workspace_size failed but wrote a size", ffseg_status(need));
    const ffseg_status st = ffseg_create(&cfg, ws.get(4096, 0), 4096, &e);
    if (st == FFSEG_OK || e != nullptr) finding("create accepted a config workspace_size refused", st);
    e = nullptr;
  }
  if (e == nullptr) {
    // Fall back to a small valid engine so the call sequence still runs.
    // Six configs, each created once and restored since (fuzz_workspace.h):
    // their creation is the same for every input.
    static ffseg_fuzz::CreatedEngine fallback[2][3];
    const uint32_t fb_objects = 1 + (cflags >> 7), fb_n = 2 + (cflags & 3) % 3;
    cfg = valid_config(fb_objects, fb_n);
    if (ffseg_workspace_size(&cfg, &need) != FFSEG_OK) finding("fallback config refused", 0);
    ffseg_status st = FFSEG_OK;
    e = fallback[fb_objects - 1][fb_n - 2].get(cfg, &st);
    if (st != FFSEG_OK || e == nullptr) finding("fallback create failed", st);
  }
  const uint32_t objects = cfg.max_objects;
  const uint32_t n = cfg.mesh_resolution;
  if (std::getenv("FFSEG_FUZZ_VERBOSE"))
    std::fprintf(stderr, "engine: %u objects, n = %u, %zu bytes\n", objects, n, need);
  const size_t NV = size_t(6) * n * n;
  const size_t NT = size_t(12) * n * n - 4;
  uint64_t work = 0;
  int recreated = 0, region_steps = 0, placements = 0;
  // Objects that may have a bounding region: placed when a step was called
  // with two or more objects placed, not placed again since, volume unchanged.
  std::vector<bool> may_have_region(objects, false);

  bool have_volume = false;
  int volume_kind = 0;
  std::vector<bool> placed(objects, false);
  ffseg_volume current;
  std::memset(&current, 0, sizeof current);

  // ---- the call sequence ----------------------------------------------------------
  int ops = 0;
  while (!in.empty() && ops++ < 64) {
    const uint8_t op = in.take<uint8_t>();
    const uint32_t object = (op & 0x80) ? pick_u32(in) : in.take<uint8_t>() % (objects + 1);
    ffseg_status st = FFSEG_OK;
    switch (op % 11) {
      case 0: {  // set_params with extreme values
        ffseg_params p;
        ffseg_params_init_default(&p);
        const uint16_t which = in.take<uint16_t>();
        if (which & 1) p.target_mode = pick_u32(in);
        if (which & 2) p.lambda_laplacian = pick_double(in);
        if (which & 4) p.lambda_position = pick_double(in);
        if (which & 8) p.lambda_uniform = pick_double(in);
        if (which & 16) p.step_size = pick_double(in);
        if (which & 32) p.flip_tau = pick_double(in);
        if (which & 64) p.search_range_mm = pick_double(in);
        if (which & 128) p.search_step_mm = pick_double(in);
        if (which & 256) p.convergence_mm = pick_double(in);
        if (which & 512) p.diffusion_iterations = pick_count(in, 100);
        if (which & 1024) p.consecutive_background = pick_u32(in);
        if (which & 2048) p.struct_size = in.take<uint8_t>();
        if (which & 8192) {  // the grey-level and bounding-region fields (chapters 5 and 6)
          const uint16_t more = in.take<uint16_t>();
          if (more & 1) p.smoothing_iterations = pick_count(in, 100);
          if (more & 2) p.bin_min_count = pick_u32(in);
          if (more & 4) p.smoothing_kappa = pick_double(in);
          if (more & 8) p.intensity_gamma = pick_double(in);
          if (more & 16) p.sigma_floor_fraction = pick_double(in);
          if (more & 32) p.bin_radius = pick_double(in);
          if (more & 64) p.bin_separation = pick_double(in);
          if (more & 128) p.partial_volume_steps = pick_count(in, 1000);
          if (more & 256) p.region_width_mm = pick_double(in);
          if (more & 512) p.border_weight = pick_double(in);
          if (more & 1024) p.region_interval = pick_u32(in);
          if (more & 2048) p.reserved1 = pick_u32(in);
          if (more & 4096) p.grey_respacing = pick_u32(in);
        }
        st = ffseg_set_params(e, (which & 4096) ? nullptr : &p);
        check_status(st, "set_params");
        if (st == FFSEG_ERR_INVALID_ARGUMENT && std::strstr(ffseg_last_error(e), "params.") == nullptr)
          finding("set_params refusal does not name the field", st);
        break;
      }
      case 1: {  // set_volume, good or with one field broken
        volume_kind = in.take<uint8_t>();
        ffseg_volume v = ph.volume(volume_kind);
        const uint8_t breakage = in.take<uint8_t>();
        switch (breakage % 12) {
          case 0: v.data_bytes -= 1 + breakage / 12; break;
          case 1: v.dims[breakage % 3] = in.take<int64_t>(); break;
          case 2: v.strides[breakage % 3] = in.take<int64_t>(); break;
          case 3: v.offset = in.take<int64_t>(); break;
          case 4: v.index_to_world[breakage % 16] = pick_double(in); break;
          case 5: v.rescale_slope = pick_double(in); break;
          case 6: v.voxel_type = in.take<uint8_t>(); break;
          case 7: v.struct_size = in.take<uint8_t>(); break;
          default: break;  // left good
        }
        st = ffseg_set_volume(e, (breakage == 255) ? nullptr : &v);
        check_status(st, "set_volume");
        if (st == FFSEG_OK) {
          have_volume = true;
          current = v;
          may_have_region.assign(objects, false);
        } else if (st != FFSEG_ERR_INVALID_VOLUME && st != FFSEG_ERR_STRUCT_SIZE && st != FFSEG_ERR_NULL_POINTER) {
          finding("set_volume: unexpected status", st);
        }
        break;
      }
      case 2: {  // init_sphere
        double c[3];
        const uint8_t mode = in.take<uint8_t>();
        if (mode & 1) {
          for (int a = 0; a < 3; ++a) c[a] = pick_double(in);
        } else {  // near the ball of the phantoms
          c[0] = 1.25 + (in.take<int8_t>() / 16.0);
          c[1] = 14.5 + (in.take<int8_t>() / 16.0);
          c[2] = 17.0 + (in.take<int8_t>() / 16.0);
        }
        const double r = (mode & 2) ? pick_double(in) : 0.5 + in.take<uint8_t>() / 16.0;
        // A placement with a volume fits the intensity model and tests the
        // sphere against the objects already placed: bounded per input.
        if (have_volume && ++placements > kMaxPlacements) break;
        st = ffseg_init_sphere(e, object, (mode & 4) ? nullptr : c, r);
        check_status(st, "init_sphere");
        if (st == FFSEG_OK) {
          if (!have_volume || object >= objects) finding("init_sphere succeeded where it cannot", st);
          placed[object] = true;
          may_have_region[object] = false;
        }
        if (!have_volume && object < objects && !(mode & 4) && st != FFSEG_ERR_MISUSE)
          finding("init_sphere without a volume is not MISUSE", st);
        if (object >= objects && st != FFSEG_ERR_OBJECT_OUT_OF_RANGE && !(mode & 4))
          finding("init_sphere: object out of range not reported", st);
        break;
      }
      case 3: {  // step
        uint64_t stepped = 0;
        for (bool b : placed) stepped += b ? 1 : 0;
        const uint64_t cost = uint64_t(n) * n * (stepped ? stepped : 1);
        const bool region_step = stepped == 2 && n == 2 && region_steps < kMaxRegionSteps;
        if (region_step) ++region_steps;
        else if (work + cost > kWorkBudget) break;  // over budget: skipped
        else work += cost;
        ffseg_step_info info;
        std::memset(&info, 0, sizeof info);
        const uint8_t mode = in.take<uint8_t>();
        info.struct_size = (mode & 1) ? mode : sizeof info;
        st = ffseg_step(e, (mode & 2) ? nullptr : &info);
        if (stepped >= 2 && have_volume)
          for (uint32_t o = 0; o < objects; ++o) may_have_region[o] = may_have_region[o] || placed[o];
        check_status(st, "step");
        bool any = false;
        for (bool b : placed) any = any || b;
        if (st >= 0 && (!have_volume || !any))
          finding("step succeeded without a volume or an object", st);
        break;
      }
      case 4: {  // extract_mesh into exact, short or missing buffers
        const uint8_t mode = in.take<uint8_t>();
        const size_t vcap = (mode & 1) ? NV - (mode >> 4) % (NV + 1) : NV;
        const size_t tcap = (mode & 2) ? NT - (mode >> 4) % (NT + 1) : NT;
        std::vector<float> xyz(3 * vcap);
        std::vector<uint32_t> tris(3 * tcap);
        size_t nv = 12345, nt = 12345;
        float* xp = (mode & 8) ? nullptr : xyz.data();
        uint32_t* tp = (mode & 4) ? nullptr : tris.data();
        st = ffseg_extract_mesh(e, object, xp, vcap, tp, tcap, &nv, &nt);
        check_status(st, "extract_mesh");
        if (st == FFSEG_OK || st == FFSEG_ERR_BUFFER_TOO_SMALL)
          if (nv != NV || nt != NT) finding("extract_mesh: wrong counts", static_cast<long long>(nv));
        if (st == FFSEG_OK && object < objects && !placed[object]) finding("extract of an unplaced object", st);
        if (st == FFSEG_OK && xp)
          for (size_t i = 0; i < 3 * NV; ++i)
            if (!std::isfinite(xyz[i])) finding("non-finite vertex", static_cast<long long>(i));
        break;
      }
      case 5: {  // rasterize, or (mode bit 2) region_mask
        const uint8_t mode = in.take<uint8_t>();
        const bool region = (mode & 4) != 0;
        const size_t count = have_volume ? size_t(current.dims[0] * current.dims[1] * current.dims[2]) : 16;
        std::vector<uint8_t> mask(count, 7);
        const int64_t* D = current.dims;
        const int64_t flipped[3] = {1, D[0], -D[0] * D[1]};
        uint8_t* base = (mode & 1) ? nullptr : mask.data();
        const int64_t* strides = nullptr;
        if ((mode & 2) && have_volume && base) {
          strides = flipped;
          base += D[0] * D[1] * (D[2] - 1);
        }
        st = region ? ffseg_region_mask(e, object, base, strides) : ffseg_rasterize(e, object, base, strides);
        check_status(st, region ? "region_mask" : "rasterize");
        if (st < 0 && ffseg_last_error(e)[0] == '\0') finding("a refusal without a message", st);
        if (st == FFSEG_OK) {
          if (!have_volume) finding("rasterize without a volume succeeded", st);
          for (uint8_t m : mask)
            if (m > 1) finding("mask value other than 0/1", m);
        }
        if (region && st == FFSEG_OK && (objects < 2 || object >= objects || !may_have_region[object]))
          finding("region_mask succeeded without a region", st);
        if (region && st == FFSEG_OK) {  // the regions of distinct objects share no voxel
          std::vector<uint8_t> other(mask.size(), 0);
          uint8_t* obase = strides ? other.data() + D[0] * D[1] * (D[2] - 1) : other.data();
          for (uint32_t o = 0; o < objects; ++o) {
            if (o == object || ffseg_region_mask(e, o, obase, strides) != FFSEG_OK) continue;
            for (size_t i = 0; i < mask.size(); ++i)  // the same layout as mask
              if (mask[i] && other[i]) finding("two objects' regions share a voxel", static_cast<long long>(i));
          }
        }
        break;
      }
      case 6: {  // sample
        double w[3];
        for (int a = 0; a < 3; ++a) w[a] = pick_double(in);
        double val = 0;
        st = ffseg_sample(e, w, pick_u32(in), (op & 0x40) ? nullptr : &val);
        check_status(st, "sample");
        break;
      }
      case 7: {  // destroy, use the stale handle, re-create in the same workspace
        // Creation costs about as much as a step (mesh, Laplacian program):
        // once per input (a second one reached no edge the first does not:
        // the corpus replays to the same cov).
        if (recreated == kMaxRecreate) break;
        ++recreated;
        ffseg_destroy(e);
        const double c[3] = {0, 0, 0};
        if (ffseg_init_sphere(e, 0, c, 1.0) != FFSEG_ERR_MISUSE) finding("init_sphere after destroy", 0);
        if (ffseg_step(e, nullptr) != FFSEG_ERR_MISUSE) finding("step after destroy", 0);
        if (ffseg_extract_mesh(e, 0, nullptr, 0, nullptr, 0, nullptr, nullptr) != FFSEG_ERR_MISUSE)
          finding("extract after destroy", 0);
        if (std::strcmp(ffseg_last_error(e), "not a live ffseg engine") != 0) finding("last_error after destroy", 0);
        ffseg_destroy(e);  // twice is harmless
        ffseg_engine* again = nullptr;
        const ffseg_status cs = ffseg_create(&cfg, e, need, &again);
        if (cs != FFSEG_OK || again != e) finding("re-create in the same workspace failed", cs);
        have_volume = false;
        for (size_t i = 0; i < placed.size(); ++i) placed[i] = false;
        may_have_region.assign(objects, false);
        break;
      }
      case 8: {  // another engine in a wrong workspace: refused, ours untouched
        std::unique_ptr<unsigned char[]> small(new unsigned char[256]);
        ffseg_engine* other = reinterpret_cast<ffseg_engine*>(small.get());
        ffseg_config c2 = valid_config(1, 2);
        st = ffseg_create(&c2, small.get(), in.take<uint8_t>(), &other);
        check_status(st, "create (small)");
        if (st == FFSEG_OK || other != nullptr) finding("create accepted a tiny workspace", st);
        break;
      }
      case 9: {  // null arguments everywhere
        const double c[3] = {0, 0, 0};
        double val;
        if (ffseg_set_params(nullptr, nullptr) != FFSEG_ERR_NULL_POINTER) finding("set_params(NULL)", 0);
        if (ffseg_set_volume(nullptr, &current) != FFSEG_ERR_NULL_POINTER) finding("set_volume(NULL)", 0);
        if (ffseg_init_sphere(nullptr, 0, c, 1) != FFSEG_ERR_NULL_POINTER) finding("init_sphere(NULL)", 0);
        if (ffseg_step(nullptr, nullptr) != FFSEG_ERR_NULL_POINTER) finding("step(NULL)", 0);
        if (ffseg_sample(nullptr, c, 0, &val) != FFSEG_ERR_NULL_POINTER) finding("sample(NULL)", 0);
        if (ffseg_sample(e, nullptr, 0, &val) != FFSEG_ERR_NULL_POINTER) finding("sample(point NULL)", 0);
        if (ffseg_rasterize(nullptr, 0, nullptr, nullptr) != FFSEG_ERR_NULL_POINTER) finding("rasterize(NULL)", 0);
        if (ffseg_region_mask(nullptr, 0, nullptr, nullptr) != FFSEG_ERR_NULL_POINTER) finding("region_mask(NULL)", 0);
        if (ffseg_region_mask(e, 0, nullptr, nullptr) != FFSEG_ERR_NULL_POINTER) finding("region_mask(mask NULL)", 0);
        if (ffseg_extract_mesh(nullptr, 0, nullptr, 0, nullptr, 0, nullptr, nullptr) != FFSEG_ERR_NULL_POINTER)
          finding("extract(NULL)", 0);
        if (ffseg_workspace_size(nullptr, nullptr) != FFSEG_ERR_NULL_POINTER) finding("workspace_size(NULL)", 0);
        if (ffseg_create(nullptr, nullptr, 0, nullptr) != FFSEG_ERR_NULL_POINTER) finding("create(NULL)", 0);
        ffseg_config_init_default(nullptr);
        ffseg_params_init_default(nullptr);
        ffseg_destroy(nullptr);
        break;
      }
      default: {  // messages and status strings
        const ffseg_status code = ffseg_status(in.take<int32_t>());
        if (ffseg_status_string(code) == nullptr) finding("status_string NULL", code);
        if (ffseg_last_error(e) == nullptr || ffseg_last_error(nullptr) == nullptr) finding("last_error NULL", 0);
        break;
      }
    }
    static const bool verbose = std::getenv("FFSEG_FUZZ_VERBOSE") != nullptr;
    if (verbose) std::fprintf(stderr, "op %d object %u: %d %s\n", op % 11, object, int(st), ffseg_last_error(e));
    // The message is always a terminated string of bounded length.
    if (std::strlen(ffseg_last_error(e)) >= 512) finding("message too long", 0);
  }

  // ---- the engine is still usable ----------------------------------------------
  ffseg_params p;
  ffseg_params_init_default(&p);
  if (ffseg_set_params(e, &p) != FFSEG_OK) finding("usable: set_params", 0);
  const ffseg_volume v = ph.volume(volume_kind);
  if (ffseg_set_volume(e, &v) != FFSEG_OK) finding("usable: set_volume", 0);
  // Disjoint spheres, 1 mm radius, 3 mm apart in the phantom's grid: init_sphere
  // refuses one that crosses, encloses or lies inside another placed object,
  // so a sphere refused for meeting a mesh the sequence left is tried again
  // after the others have moved, for as long as a pass places one. What is
  // left is a cycle (A's new sphere meets B's old mesh and B's new sphere
  // A's old mesh): the API has no call that would remove a mesh, so there
  // the refusal itself, with the overlap message, is the right answer.
  placed[objects - 1] = true;
  std::vector<bool> pending(placed);
  for (bool progress = true; progress;) {
    progress = false;
    for (uint32_t o = 0; o < objects; ++o) {
      if (!pending[o]) continue;
      const double c[3] = {-3.25 + 3.0 * (o % 4), 10.0 + 3.0 * (o / 4 % 4), 17.0 - 6.0 * (o / 16)};
      const ffseg_status st = ffseg_init_sphere(e, o, c, 1.0);
      if (st == FFSEG_OK) {
        pending[o] = false;
        progress = true;
      } else if (st != FFSEG_ERR_INVALID_ARGUMENT || !std::strstr(ffseg_last_error(e), "overlaps object")) {
        finding("usable: init_sphere", o);
      }
    }
  }
  // The mesh extracted below: the first object placed again here.
  uint32_t with_mesh = objects;
  for (uint32_t o = 0; o < objects && with_mesh == objects; ++o)
    if (placed[o] && !pending[o]) with_mesh = o;
  uint64_t stepped = 0;
  for (bool b : placed) stepped += b ? 1 : 0;
  // The final step runs for one input in kFinalStepShare (an engine's first
  // step is most of an input's time); the others check everything but it.
  if (work + uint64_t(n) * n * stepped <= kWorkBudget && ffseg_fuzz::input_hash(data, size) % kFinalStepShare == 0) {
    const ffseg_status st = ffseg_step(e, nullptr);
    if (st != FFSEG_OK && st != FFSEG_CONVERGED && st != FFSEG_DEGENERATE) finding("usable: step", st);
  }
  std::vector<float> xyz(3 * NV);
  std::vector<uint32_t> tris(3 * NT);
  size_t nv = 0, nt = 0;
  if (with_mesh < objects &&
      ffseg_extract_mesh(e, with_mesh, xyz.data(), NV, tris.data(), NT, &nv, &nt) != FFSEG_OK)
    finding("usable: extract", 0);
  for (float f : xyz)
    if (!std::isfinite(f)) finding("usable: non-finite vertex", 0);
  ffseg_destroy(e);
  return 0;
}
