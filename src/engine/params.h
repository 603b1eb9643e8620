// The engine's configuration (fixed at create: it sizes the workspace) and
// its parameters (changeable between steps), with their validation.
#pragma once
#include <cstddef>
#include <cstdint>

#include "errors.h"

namespace ffseg {

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

}  // namespace ffseg
