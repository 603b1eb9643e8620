// libFuzzer target "volume": an arbitrary volume descriptor over honest voxel
// bytes, then the whole pipeline through the C API.
//
// Input layout (little-endian, read from the front; missing bytes read as 0):
//   u8  type      voxel_type = type % 8 (0 and 7 are invalid on purpose)
//   u8  flags     bit0 raw dims      (3 x i64)   else 3 x u8: dims = 1 + v % 16
//                 bit1 raw strides   (3 x i64)   else contiguous from a layout byte
//                 bit2 raw offset    (i64)       else the offset the layout needs
//                 bit3 raw affine    (16 x f64)  else spacing/rotation/translation bytes
//                 bit4 raw rescale   (2 x f64)   else slope 1, intercept 0
//                 bit5 raw sphere    (4 x f64)   else centre/radius bytes
//                 bit6 params        (7 bytes)   else the defaults
//                 bit7 re-set a broken copy of the descriptor after the steps
//   u8  mesh      mesh_resolution = 2 + (mesh & 127) % 3   (2..4); bit7: a
//                 binary-only engine (config.target_mode = FFSEG_TARGET_BINARY)
//   u8  steps     ffseg_step calls = steps % 8 within the budget below;
//                 bit7: also rasterize through reversed-k strides
//   ...  the fields the flags select, in the order above
//   rest          the voxel bytes: data_bytes is exactly their count
//
// The voxels are copied into a heap block of exactly that size, so ASan
// reports any read outside [data, data + data_bytes). Checked invariants: every
// call returns a documented status; a refused volume leaves a message and no
// volume; accepted volumes can be sampled at their 8 corner voxels; meshes have
// 6 n^2 finite vertices; rasterized masks hold only 0 and 1.
//
// Work per input is bounded so that the target runs at about a thousand inputs
// per second under ASan and UBSan: at most 4096 voxels (the input's length; a
// larger grid needs overlapping strides, which are refused), meshes of n <= 4,
// and steps costing n^2 each (grey-level steps 2 n^2) from kStepBudget: two
// binary steps at n = 2 or one grey-level step, one binary step at n = 3, none
// at n = 4 (bit7's step after the refused re-set is one of these). A step is
// what costs (CPU under ASan + UBSan, measured: binary 0.4-0.6 ms at n = 2,
// 1 ms at n = 3, grey-level 1.3-2.7 ms at n = 2), so an input at n = 3 steps
// only when its hash is 0 modulo kLargeStepShare. The engine is created once
// per configuration and restored for each input (fuzz_workspace.h).
// What this target is after is the volume: odd layouts, affines and values
// through every stage; mesh sizes and call orders are fuzz_calls' part.
// Every stage stays reachable: grey-level targets and every parameter through
// the params block.
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

// Mesh-resolution-squared steps per input (a step's cost grows with 6 n^2).
constexpr int kStepBudget = 9;
// Inputs at n >= 3 step only when their hash is 0 modulo this (see the step loop).
constexpr uint32_t kLargeStepShare = 4;

[[noreturn]] void finding(const char* what, ffseg_status st) {
  std::fprintf(stderr, "fuzz_volume: %s (status %d)\n", what, int(st));
  std::abort();
}

void expect_one_of(ffseg_status st, std::initializer_list<ffseg_status> ok, const char* what) {
  for (ffseg_status s : ok)
    if (s == st) return;
  finding(what, st);
}

size_t type_size(uint32_t t) {
  switch (t) {
    case FFSEG_U8: return 1;
    case FFSEG_I16: case FFSEG_U16: return 2;
    case FFSEG_I32: case FFSEG_F32: return 4;
    case FFSEG_F64: return 8;
    default: return 1;
  }
}

// The engine for mesh resolution n: created by the first input of each n and
// configuration, restored for later ones (fuzz_workspace.h: creation is the
// same work for every input and was a quarter of this target's time). A
// binary-only configuration (FFSEG_TARGET_BINARY) carves no grey-level
// buffers: grey-level params are refused there.
struct Engine {
  ffseg_engine* e = nullptr;
  Engine(uint32_t n, bool binary_only) {
    static ffseg_fuzz::CreatedEngine engines[3][2];
    ffseg_config c;
    ffseg_config_init_default(&c);
    c.max_objects = 2;
    c.mesh_resolution = n;
    c.max_roi_voxels = int64_t(1) << 16;
    c.target_mode = binary_only ? FFSEG_TARGET_BINARY : FFSEG_TARGET_INTENSITY;
    ffseg_status st = FFSEG_OK;
    e = engines[n - 2][binary_only].get(c, &st);
    if (st != FFSEG_OK) finding("create failed with the exact size", st);
  }
  ~Engine() { ffseg_destroy(e); }
};

void to_world(const double A[16], const double ijk[3], double w[3]) {
  for (int r = 0; r < 3; ++r) w[r] = A[4 * r] * ijk[0] + A[4 * r + 1] * ijk[1] + A[4 * r + 2] * ijk[2] + A[4 * r + 3];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Reader in{data, size};
  const uint32_t type = in.take<uint8_t>() % 8;
  const uint8_t flags = in.take<uint8_t>();
  const uint8_t mesh_byte = in.take<uint8_t>();
  const uint32_t n = 2 + (mesh_byte & 127) % 3;
  const bool binary_only = (mesh_byte & 128) != 0;
  const uint8_t steps_byte = in.take<uint8_t>();
  const int nsteps_asked = steps_byte % 8;
  const int64_t es = int64_t(type_size(type));

  ffseg_volume v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.voxel_type = type;

  // Dimensions.
  if (flags & 1) {
    for (int a = 0; a < 3; ++a) v.dims[a] = in.take<int64_t>();
  } else {
    for (int a = 0; a < 3; ++a) v.dims[a] = 1 + in.take<uint8_t>() % 16;
  }
  // Strides: raw, or a contiguous layout with optional flipped axes, padded
  // rows and a permuted axis order.
  const bool small_dims = v.dims[0] >= 1 && v.dims[0] <= 4096 && v.dims[1] >= 1 && v.dims[1] <= 4096 &&
                          v.dims[2] >= 1 && v.dims[2] <= 4096;
  int64_t natural_offset = 0;
  if (flags & 2) {
    for (int a = 0; a < 3; ++a) v.strides[a] = in.take<int64_t>();
  } else {
    const uint8_t layout = in.take<uint8_t>();
    if (small_dims) {
      static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
      const int* order = perms[(layout >> 4) % 6];
      int64_t step = es;
      for (int x = 0; x < 3; ++x) {
        const int a = order[x];
        v.strides[a] = step;
        step *= v.dims[a];
        if (x == 0 && (layout & 8)) step += es;  // one padding voxel per row
      }
      for (int a = 0; a < 3; ++a)
        if (layout & (1 << a)) {
          natural_offset += v.strides[a] * (v.dims[a] - 1);
          v.strides[a] = -v.strides[a];
        }
    }
  }
  v.offset = (flags & 4) ? in.take<int64_t>() : natural_offset;

  // Affine.
  if (flags & 8) {
    for (int q = 0; q < 16; ++q) v.index_to_world[q] = in.take<double>();
  } else {
    double sp[3];
    for (int a = 0; a < 3; ++a) sp[a] = 0.25 + 0.25 * (in.take<uint8_t>() % 16);
    const double ang = in.take<uint8_t>() * (M_PI / 128);
    const double c = std::cos(ang), s = std::sin(ang);
    const double R[9] = {c, -s, 0, s * 0.6, c * 0.6, -0.8, s * 0.8, c * 0.8, 0.6};
    for (int r = 0; r < 3; ++r) {
      for (int a = 0; a < 3; ++a) v.index_to_world[4 * r + a] = R[3 * r + a] * sp[a];
      v.index_to_world[4 * r + 3] = double(in.take<int8_t>()) * 2.5;
    }
    v.index_to_world[15] = 1;
  }
  if (flags & 16) {
    v.rescale_slope = in.take<double>();
    v.rescale_intercept = in.take<double>();
  } else {
    v.rescale_slope = 1;
    v.rescale_intercept = 0;
  }
  double centre[3], radius;
  if (flags & 32) {
    for (int a = 0; a < 3; ++a) centre[a] = in.take<double>();
    radius = in.take<double>();
  } else {
    double ijk[3];
    for (int a = 0; a < 3; ++a) {
      const double d = small_dims ? double(v.dims[a]) : 8.0;
      ijk[a] = -0.5 + d * (in.take<uint8_t>() / 255.0);
    }
    to_world(v.index_to_world, ijk, centre);
    radius = 0.25 * (1 + in.take<uint8_t>() % 64);
  }
  ffseg_params prm;
  ffseg_params_init_default(&prm);
  const bool set_params = (flags & 64) != 0;
  // Without a params block the defaults, except for a 16 mm search instead of
  // the automatic 80 mm: sampling 80 mm along every normal at a quarter of the
  // finest 0.25 mm spacing was the largest cost of a step here. The automatic
  // range stays reachable (a params block with a range byte of 0).
  prm.search_range_mm = 16;
  if (set_params) {
    prm.step_size = (1 + in.take<uint8_t>()) / 256.0;
    prm.search_range_mm = in.take<uint8_t>() * 0.25;  // 0: the automatic range
    prm.search_step_mm = in.take<uint8_t>() * 0.05;
    prm.flip_tau = in.take<uint8_t>() / 256.0;
    prm.diffusion_iterations = in.take<uint8_t>() % 12;
    prm.lambda_uniform = in.take<uint8_t>() / 16.0;
    // bit0 grey-level targets; bits 1-2 partial_volume_steps; bits 3-4
    // smoothing_iterations; bits 5-7 intensity_gamma in (0, 1).
    const uint8_t mode = in.take<uint8_t>();
    prm.target_mode = (mode & 1) ? FFSEG_TARGET_INTENSITY : FFSEG_TARGET_BINARY;
    prm.partial_volume_steps = (mode >> 1) & 3;
    prm.smoothing_iterations = (mode >> 3) & 3;
    prm.intensity_gamma = (1 + (mode >> 5)) / 9.0;
  }

  // The voxel bytes: an exact heap block, so any stray read is an ASan report.
  const size_t nbytes = in.n;
  std::unique_ptr<uint8_t[]> voxels(new uint8_t[nbytes]);
  if (nbytes) std::memcpy(voxels.get(), in.p, nbytes);
  v.data = voxels.get();
  v.data_bytes = nbytes;

  Engine eng(n, binary_only);
  ffseg_engine* e = eng.e;
  const ffseg_status sp = ffseg_set_params(e, &prm);
  if (sp == FFSEG_ERR_INVALID_ARGUMENT && binary_only && prm.target_mode == FFSEG_TARGET_INTENSITY) {
    // Grey-level params on a binary-only engine: refused, the defaults stay;
    // the same params with binary targets are accepted.
    prm.target_mode = FFSEG_TARGET_BINARY;
    expect_one_of(ffseg_set_params(e, &prm), {FFSEG_OK}, "set_params (binary) after a refused intensity");
  } else {
    expect_one_of(sp, {FFSEG_OK}, "set_params");
  }

  const ffseg_status sv = ffseg_set_volume(e, &v);
  static const bool verbose = std::getenv("FFSEG_FUZZ_VERBOSE") != nullptr;
  if (verbose) std::fprintf(stderr, "set_volume: %d %s\n", int(sv), ffseg_last_error(e));
  if (sv != FFSEG_OK) {
    if (sv != FFSEG_ERR_INVALID_VOLUME) finding("set_volume: unexpected status", sv);
    if (ffseg_last_error(e)[0] == '\0') finding("set_volume refused without a message", sv);
    // No volume: everything that needs one is misuse.
    expect_one_of(ffseg_init_sphere(e, 0, centre, 1.0), {FFSEG_ERR_MISUSE, FFSEG_ERR_INVALID_ARGUMENT}, "init_sphere without volume");
    expect_one_of(ffseg_step(e, nullptr), {FFSEG_ERR_MISUSE}, "step without volume");
    return 0;
  }

  // Read the 8 corner voxels and the centre through the sampler.
  for (int c = 0; c < 9; ++c) {
    double ijk[3];
    for (int a = 0; a < 3; ++a)
      ijk[a] = c < 8 ? ((c >> a) & 1 ? double(v.dims[a] - 1) : 0.0) : 0.5 * double(v.dims[a] - 1);
    double w[3], val = 0;
    to_world(v.index_to_world, ijk, w);
    if (!std::isfinite(w[0]) || !std::isfinite(w[1]) || !std::isfinite(w[2])) continue;
    expect_one_of(ffseg_sample(e, w, FFSEG_SAMPLE_NEAREST, &val), {FFSEG_OK}, "sample nearest");
    expect_one_of(ffseg_sample(e, w, FFSEG_SAMPLE_LINEAR, &val), {FFSEG_OK}, "sample linear");
  }

  const ffseg_status si = ffseg_init_sphere(e, 0, centre, radius);
  if (verbose) std::fprintf(stderr, "init_sphere: %d %s\n", int(si), ffseg_last_error(e));
  expect_one_of(si, {FFSEG_OK, FFSEG_ERR_INVALID_ARGUMENT, FFSEG_ERR_SPHERE_OUTSIDE}, "init_sphere");
  if (si != FFSEG_OK) {
    expect_one_of(ffseg_step(e, nullptr), {FFSEG_ERR_MISUSE}, "step without sphere");
    return 0;
  }
  // The step budget (see the top): grey-level steps count twice (the crop's
  // smoothing and the model fit come on top of the binary step's work).
  const int step_cost = int(n * n) * (prm.target_mode == FFSEG_TARGET_INTENSITY ? 2 : 1);
  // A step at n = 3 costs twice one at n = 2 (about 1 ms of CPU) and was
  // taken by 40% of the inputs run; one input in kLargeStepShare gets it.
  int budget = (n <= 2 || ffseg_fuzz::input_hash(data, size) % kLargeStepShare == 0) ? kStepBudget : 0;
  for (int s = 0; s < nsteps_asked && budget >= step_cost; ++s, budget -= step_cost) {
    ffseg_step_info info;
    std::memset(&info, 0, sizeof info);
    info.struct_size = sizeof info;
    const ffseg_status st = ffseg_step(e, &info);
    if (verbose) std::fprintf(stderr, "step: %d with_target %u moved %g %s\n", int(st), info.vertices_with_target[0],
                              info.mean_displacement_mm[0], ffseg_last_error(e));
    // Grey-level targets: a sphere holding no voxel centre of its crop is
    // SPHERE_OUTSIDE at the first step (finding 4 of FUZZING.md).
    if (st == FFSEG_ERR_SPHERE_OUTSIDE && prm.target_mode == FFSEG_TARGET_INTENSITY) break;
    expect_one_of(st, {FFSEG_OK, FFSEG_CONVERGED, FFSEG_DEGENERATE, FFSEG_ERR_NUMERIC, FFSEG_ERR_ROI_TOO_LARGE}, "step");
    if (st < 0) break;
    // One object: its flags are all the flags, and at rest they alone tell
    // a degenerate result from a converged one.
    constexpr uint32_t kKnownFlags = FFSEG_OBJECT_NO_BOUNDARY | FFSEG_OBJECT_FILLS_GRID | FFSEG_OBJECT_STALLED;
    if (info.flags_all != info.object_flags[0] || (info.flags_all & ~kKnownFlags) != 0)
      finding("step: flags_all is not object 0's flags", st);
    if (st != FFSEG_OK && (st == FFSEG_DEGENERATE) != (info.flags_all != 0))
      finding("step: status and flags disagree", st);
  }
  if ((flags & 128) && budget >= step_cost) {
    // A broken descriptor is refused and the accepted volume stays.
    ffseg_volume bad = v;
    bad.data_bytes = 0;
    expect_one_of(ffseg_set_volume(e, &bad), {FFSEG_ERR_INVALID_VOLUME}, "set_volume with data_bytes 0");
    const ffseg_status st = ffseg_step(e, nullptr);
    if (!(st == FFSEG_ERR_SPHERE_OUTSIDE && prm.target_mode == FFSEG_TARGET_INTENSITY))
      expect_one_of(st, {FFSEG_OK, FFSEG_CONVERGED, FFSEG_DEGENERATE, FFSEG_ERR_NUMERIC, FFSEG_ERR_ROI_TOO_LARGE},
                    "step after refused volume");
  }

  size_t nv = 0, nt = 0;
  expect_one_of(ffseg_extract_mesh(e, 0, nullptr, 0, nullptr, 0, &nv, &nt), {FFSEG_OK}, "extract counts");
  if (nv != size_t(6) * n * n) finding("vertex count is not 6 n^2", int(nv));
  std::vector<float> xyz(3 * nv);
  std::vector<uint32_t> tris(3 * nt);
  expect_one_of(ffseg_extract_mesh(e, 0, xyz.data(), nv, tris.data(), nt, &nv, &nt), {FFSEG_OK}, "extract");
  for (float f : xyz)
    if (!std::isfinite(f)) finding("non-finite vertex in the mesh", 0);
  for (uint32_t t : tris)
    if (t >= nv) finding("triangle index out of range", int(t));

  // Rasterize into a mask sized from the accepted dims (at most 4096 voxels:
  // a larger grid needs more bytes than max_len or overlapping strides).
  const int64_t voxels_n = v.dims[0] * v.dims[1] * v.dims[2];
  if (voxels_n <= (int64_t(1) << 20)) {
    std::unique_ptr<uint8_t[]> mask(new uint8_t[size_t(voxels_n)]);
    expect_one_of(ffseg_rasterize(e, 0, mask.get(), nullptr), {FFSEG_OK}, "rasterize");
    for (int64_t q = 0; q < voxels_n; ++q)
      if (mask[size_t(q)] > 1) finding("mask value other than 0/1", mask[size_t(q)]);
    if (steps_byte & 128) {
      // Reversed k axis: the same voxels through negative strides.
      const int64_t strides[3] = {1, v.dims[0], -v.dims[0] * v.dims[1]};
      std::unique_ptr<uint8_t[]> flipped(new uint8_t[size_t(voxels_n)]);
      expect_one_of(ffseg_rasterize(e, 0, flipped.get() + (v.dims[2] - 1) * v.dims[0] * v.dims[1], strides),
                    {FFSEG_OK}, "rasterize flipped");
      for (int64_t k = 0; k < v.dims[2]; ++k)
        for (int64_t q = 0; q < v.dims[0] * v.dims[1]; ++q)
          if (mask[size_t(k * v.dims[0] * v.dims[1] + q)] !=
              flipped[size_t((v.dims[2] - 1 - k) * v.dims[0] * v.dims[1] + q)])
            finding("rasterize with negative strides differs", 0);
    }
  }
  expect_one_of(ffseg_rasterize(e, 1, nullptr, nullptr), {FFSEG_ERR_NULL_POINTER}, "rasterize NULL mask");
  expect_one_of(ffseg_extract_mesh(e, 1, nullptr, 0, nullptr, 0, &nv, &nt), {FFSEG_ERR_MISUSE}, "extract unplaced");
  return 0;
}
