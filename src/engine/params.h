// The engine's configuration (fixed at create: it sizes the workspace) and
// its parameters (changeable between steps), with their validation. Params is
// generated from param_table.h, the one list of the parameters.
#pragma once
#include <cstddef>
#include <cstdint>

#include "errors.h"
#include "param_table.h"

namespace ffseg {

enum class TargetMode : uint32_t { binary = 0, intensity = 1 };

struct Config {
  uint32_t max_objects = 1;
  uint32_t mesh_resolution = 33;
  int64_t max_roi_voxels = int64_t(1) << 22;
  // Several objects: the voxels (or cells) of one bounding region's march and
  // times; 0: max_roi_voxels. A larger box is marched on coarser cells
  // (bounding_region.h).
  int64_t max_region_voxels = 0;
  int64_t region_voxels() const { return max_region_voxels > 0 ? max_region_voxels : max_roi_voxels; }
  // intensity: the grey-level buffers are reserved and either mode may be set;
  // binary: none are (Engine::layout), and set_params refuses intensity.
  TargetMode target_mode = TargetMode::intensity;
};

struct Params {
#define FFSEG_PARAM_MEMBER(name, ctype, kind, def, lo, hi, bounds, unit, doc) ctype name = ctype(def);
  FFSEG_PARAM_TABLE(FFSEG_PARAM_MEMBER)
#undef FFSEG_PARAM_MEMBER
  // Notes on the defaults: intensity_gamma was chosen on the right-hemisphere
  // Colin27 structures only (issue #4); partial_volume_steps = 4 steps of
  // step_size 0.5 cover 1 - 0.5^4 = 94% of a boundary's move.

  // Several objects (thesis chapter 6): region_width_mm is w_i of eq.
  // 6.2.6-6.2.11, 0 meaning kRegionWidthMm.
  double region_width() const { return region_width_mm > 0 ? region_width_mm : kRegionWidthMm; }
  // The automatic w_i: wide enough that a mesh keeps a few steps' motion of
  // room before its region is recomputed (at the latest when it comes
  // within w_i / 2 of its box), narrow enough that a front marches through
  // a shell of some 10 voxels instead of a whole scene.
  static constexpr double kRegionWidthMm = 10;

  // The search range in mm: search_range_mm, or when it is 0 the automatic
  // range of the target mode's search (kBinarySearchRangeMm in
  // binary_search.h, kIntensitySearchRangeMm in intensity_search.h).
  double range_mm() const;
};

// Checks a configuration; on failure writes the offending field into msg.
Err check_config(const Config& c, char* msg, size_t msg_len);
// Checks parameters against param_table.h's ranges; on failure names the
// first field out of range, its value and the range.
Err check_params(const Params& p, char* msg, size_t msg_len);

}  // namespace ffseg
