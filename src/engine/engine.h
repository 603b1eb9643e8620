// The engine: everything it owns lives in the caller's workspace, laid out by
// one function that runs twice (measure, then carve), so the size query is exact.
#pragma once
#include <cstddef>
#include <cstdint>

#include "arena.h"
#include "cpu_dispatch.h"
#include "crop_pool.h"
#include "cubesphere.h"
#include "errors.h"
#include "object.h"
#include "params.h"
#include "step_report.h"
#include "volume.h"

namespace ffseg {

class Engine {
 public:
  static constexpr size_t kMsgLen = 512;

  // Exact workspace bytes for c (c must have passed check_config). image
  // (optional, sizeof(Engine) bytes) receives the measured engine's bytes:
  // its fields as a created engine's would be, but every address it would
  // hold into the workspace null, so that the C API can tell those words
  // from fields whose values merely fall in the workspace's address range (a
  // double's high word on a 32-bit target).
  static size_t workspace_bytes(const Config& c, unsigned char* image = nullptr);
  // Builds an engine at the start of the workspace (64-byte aligned, at least
  // workspace_bytes(c) long).
  static Engine* create(const Config& c, void* ws, size_t bytes);

  Err set_params(const Params& p);
  const Params& params() const { return params_; }
  Err set_volume(const VolumeDesc& d);
  Err sample(const double w[3], uint32_t mode, double* value) const;
  Err init_sphere(uint32_t object, const double c[3], double r);
  // The mesh of a cube-sphere of resolution n_src (xyz: 3 floats per vertex,
  // 6 n_src^2 vertices) resampled to this engine's resolution
  // (cubesphere_resample.h); the model from the sphere (c, r) as for
  // init_sphere.
  Err init_mesh(uint32_t object, const double c[3], double r, const float* xyz, uint32_t n_src);
  Err extract_mesh(uint32_t object, float* xyz, size_t xyz_cap, uint32_t* tris, size_t tri_cap,
                   size_t* nv, size_t* nt) const;
  Err rasterize(uint32_t object, uint8_t* mask, const int64_t strides[3]) const;
  // 1 where object owns the voxel (regions().owner), 0 elsewhere, over the
  // whole grid (strides as rasterize's). Misuse while the object has no
  // region: a one-object engine, or no step yet with two objects placed.
  Err region_mask(uint32_t object, uint8_t* mask, const int64_t strides[3]) const;
  // One deformation step of every placed, unconverged object (Algorithm 1):
  // each stage runs over all of them before the next.
  Err step(StepReport* report);
  uint32_t steps_taken() const { return steps_; }

  const char* message() const { return msg_; }
  void clear_message() { msg_[0] = '\0'; }
  char* message_buffer() { return msg_; }

  const Config& config() const { return cfg_; }
  const CubeSphere& mesh() const { return mesh_; }
  const VolumeView& volume() const { return vol_; }
  const Object& object(uint32_t i) const { return objects_[i]; }
  // Several objects: every object's bounding region, for the ownership test
  // (count 0 in a one-object engine).
  RegionSet regions() const { return RegionSet{region_maps_, region_maps_ ? cfg_.max_objects : 0}; }
  uint32_t magic() const { return magic_; }
  void retire() { magic_ = 0; }

  static constexpr uint32_t kMagic = 0xFF5E6001u;

 private:
  Engine() = default;
  void layout(Arena& a);
  Err check_object(uint32_t object, bool must_be_placed) const;
  // init_sphere's and init_mesh's checks of the object and its sphere (call
  // names the caller in messages), the object a mesh at positions x (3 nv)
  // would overlap (max_objects: none), and the placement of x.
  Err check_seed(const char* call, uint32_t object, const double c[3], double r);
  uint32_t overlapped_object(uint32_t object, const double* x);
  void place(uint32_t object, const double c[3], double r, const double* x);
  // Object o's rule: whether its grey levels re-space (grey_respacing).
  ConvergenceRule rule(const Object& o) const;
  Err update_regions();
  friend struct EngineTesting;

  uint32_t magic_ = 0;
  Config cfg_;
  CpuDispatch cpu_;  // chosen at create, handed to every kernel-running object by layout()
  Params params_;
  CubeSphere mesh_;
  VolumeView vol_;
  Object* objects_ = nullptr;
  RegionMap* region_maps_ = nullptr;  // several objects: object i's bounding region
  StepScratch scratch_;
  // Several objects with grey-level targets: their smoothed crops share one
  // room of max_objects x max_roi_voxels (crop_pool.h), and one sweep scratch.
  CropPool crops_;
  float* crop_scratch_ = nullptr;
  uint32_t steps_ = 0;
  bool naive_ = false;
  // EngineTesting::SpeedTables: the regions' kept speed tables as built
  // (kept), never kept (none), or kept across model changes (stale: what
  // a missed invalidation would do).
  uint8_t speed_tables_ = 0;
  bool solver_failed_ = false;
  char msg_[kMsgLen] = {};
};

}  // namespace ffseg
