// The engine: everything it owns lives in the caller's workspace, laid out by
// one function that runs twice (measure, then carve), so the size query is exact.
#pragma once
#include <cstddef>
#include <cstdint>

#include "arena.h"
#include "band_cholesky.h"
#include "cubesphere.h"
#include "intensity_model.h"
#include "laplacian_system.h"
#include "smoothing.h"
#include "mesh_intersection.h"
#include "self_intersection.h"
#include "volume.h"

namespace ffseg {

enum class Err : int {
  ok = 0,
  converged,
  invalid_argument,
  null_pointer,
  workspace_too_small,
  workspace_misaligned,
  invalid_volume,
  object_out_of_range,
  buffer_too_small,
  misuse,
  numeric,
  roi_too_large,
  sphere_outside,
  config_too_large,
  not_implemented,
};

struct Config {
  uint32_t max_objects = 1;
  uint32_t mesh_resolution = 33;
  int64_t max_roi_voxels = int64_t(1) << 22;
};

enum class TargetMode : uint32_t { binary = 0, intensity = 1 };

struct Params {
  TargetMode target_mode = TargetMode::binary;
  double lambda_laplacian = 1.0;
  double lambda_position = 1.0;
  double lambda_uniform = 0.25;
  double step_size = 0.5;
  double flip_tau = 0.2;
  double search_range_mm = 0.0;  // 0: kBinaryRange or kIntensityRange
  double search_step_mm = 0.0;
  double convergence_mm = 0.05;
  uint32_t diffusion_iterations = 0;  // 0: diffusion_rounds(n)
  uint32_t consecutive_background = 3;
  uint32_t smoothing_iterations = 5;
  uint32_t bin_min_count = 0;
  double smoothing_kappa = 0;
  double intensity_gamma = 0.2;  // chosen on the right-hemisphere Colin27 structures only (issue #4)
  double sigma_floor_fraction = 0.05;
  double bin_radius = 0;
  double bin_separation = 0;
  // Grey-level targets: once an object comes to rest on the g crossings, this
  // many more steps with partial-volume boundaries (intensity_search.h), or
  // until it rests again; 0: off. 4 steps of step_size 0.5 cover 1 - 0.5^4 =
  // 94% of a boundary's move.
  uint32_t partial_volume_steps = 4;

  static constexpr double kBinaryRange = 80.0;
  static constexpr double kIntensityRange = 20.0;
  double range_mm() const {
    if (search_range_mm > 0) return search_range_mm;
    return target_mode == TargetMode::binary ? kBinaryRange : kIntensityRange;
  }
};

// Checks a configuration; on failure writes the offending field into msg.
Err check_config(const Config& c, char* msg, size_t msg_len);
// Checks parameters; on failure names the field.
Err check_params(const Params& p, char* msg, size_t msg_len);

struct Object {
  bool placed = false;
  double center[3] = {0, 0, 0};
  double radius = 0;
  double* x = nullptr;  // 3 * nv current vertex positions, mm
  // Grey-level targets: the smoothed crop around the mesh and the intensity
  // model learned from the initial sphere (fitted at the first step).
  SmoothedRoi roi;
  IntensityModel model;
  double kappa = 0;  // the conductance used, kept when the crop is recomputed
  bool polish = false;  // came to rest once: diffusion reduced (engine.cpp)
  // Grey-level targets: came to rest once, now on partial-volume boundaries
  // (intensity_search.h) for at most Params::partial_volume_steps steps.
  bool refining = false;
  uint32_t refine_steps = 0;
  bool converged = false;  // at rest for good: later steps leave it where it is
  void restart() {  // move again from where it is
    converged = false;
    refining = false;
    refine_steps = 0;
  }
};

enum Stage : int {
  kStageSearch = 0,
  kStageFlips,
  kStageDiffusion,
  kStageIntersection,
  kStageAssembly,
  kStageFactor,
  kStageSolve,
  kStageFeatures,
  kStageGuard,
  kStageCount
};

constexpr uint32_t kReportObjects = 16;

struct StepReport {
  uint32_t step_index = 0;
  uint32_t active_objects = 0;
  double mean_displacement_mm[kReportObjects] = {};
  uint32_t with_target[kReportObjects] = {};
  uint32_t flips_avoided[kReportObjects] = {};
  uint32_t folds_avoided[kReportObjects] = {};
  uint32_t border_vertices[kReportObjects] = {};
  // Vertices that moved more than kStillFactor * convergence_mm this step.
  uint32_t moving[kReportObjects] = {};
  uint64_t stage_us[kStageCount] = {};
};

// Per-step working memory shared by all objects (they are stepped one after
// the other).
struct StepScratch {
  double* normals = nullptr;  // 3 nv
  double* target = nullptr;   // 3 nv: v_i, then p_i
  double* disp = nullptr;     // 3 nv
  double* tmp = nullptr;      // 3 nv
  double* rhs = nullptr;      // 3 nv (three columns)
  double* weight = nullptr;   // nv
  uint8_t* has = nullptr;     // nv
  uint8_t* tmp_has = nullptr; // nv
  uint8_t* flipping = nullptr;// nv
  uint32_t* seq = nullptr;    // loop_len
  uint32_t* queue = nullptr;  // nv
  IntersectionScratch folds;
  TriangleScratch triangles;
  TwoRingGraph pattern;
  EnvelopeCholesky solver;
  LaplacianProgram program;  // the solver's entries as assembly writes them
  void carve(Arena& a, const CubeSphere& m);
};

class Engine {
 public:
  static constexpr size_t kMsgLen = 512;

  // Exact workspace bytes for c (c must have passed check_config).
  static size_t workspace_bytes(const Config& c);
  // Builds an engine at the start of the workspace (64-byte aligned, at least
  // workspace_bytes(c) long).
  static Engine* create(const Config& c, void* ws, size_t bytes);

  Err set_params(const Params& p);
  const Params& params() const { return params_; }
  Err set_volume(const VolumeDesc& d);
  Err sample(const double w[3], uint32_t mode, double* value) const;
  Err init_sphere(uint32_t object, const double c[3], double r);
  Err extract_mesh(uint32_t object, float* xyz, size_t xyz_cap, uint32_t* tris, size_t tri_cap,
                   size_t* nv, size_t* nt) const;
  Err rasterize(uint32_t object, uint8_t* mask, const int64_t strides[3]) const;
  // One deformation step of every placed object (Algorithm 1).
  Err step(StepReport* report);
  // Test hook: the naive variant of thesis fig. 4.10 (vertices move straight
  // towards their targets; no flip or fold handling, no Laplacian solve).
  void set_naive(bool on) { naive_ = on; }
  uint32_t steps_taken() const { return steps_; }

  const char* message() const { return msg_; }
  void clear_message() { msg_[0] = '\0'; }
  char* message_buffer() { return msg_; }

  const Config& config() const { return cfg_; }
  const CubeSphere& mesh() const { return mesh_; }
  const VolumeView& volume() const { return vol_; }
  const Object& object(uint32_t i) const { return objects_[i]; }
  uint32_t magic() const { return magic_; }
  void retire() { magic_ = 0; }

  static constexpr uint32_t kMagic = 0xFF5E6001u;

 private:
  Engine() = default;
  void layout(Arena& a);
  Err check_object(uint32_t object, bool must_be_placed) const;
  Err step_object(uint32_t i, StepReport* r, uint32_t slot);
  Err update_features(Object& o, StepReport* r);

  uint32_t magic_ = 0;
  Config cfg_;
  Params params_;
  CubeSphere mesh_;
  VolumeView vol_;
  Object* objects_ = nullptr;
  StepScratch scratch_;
  uint32_t steps_ = 0;
  bool naive_ = false;
  bool solver_failed_ = false;
  char msg_[kMsgLen] = {};
};

}  // namespace ffseg
