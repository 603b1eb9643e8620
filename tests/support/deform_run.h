// One object stepped on a phantom through the C API until it converges
// or a step budget ends: Dice of the rasterised mesh, and the worst
// self-intersections and normal flips seen after the steps (thesis chapter 4).
// Used by tests/deform's whole-run tests and tools/experiments/experiment_deform.
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>

#include "ffseg.h"
#include "support/phantoms.h"

namespace ffseg_test {

struct DeformRunResult {
  double dice = 0;
  int steps = 0;
  bool converged = false;
  size_t intersections = 0;  // worst over all steps
  size_t flips = 0;          // worst over all steps
  bool closed = true;
  ffseg_status last = FFSEG_OK;
};

struct DeformRunOptions {
  uint32_t n = 21;
  double alpha = 0.5;
  double center[3] = {0, 0, 0};
  double radius = 10;
  int max_steps = 150;
  bool check_every_step = true;
  bool naive = false;
  bool verbose = false;
  double search_range = 0;  // 0: the default
  double convergence = 0;   // 0: the default
  // >= 0: grey levels instead of the binary mask: the object at 100, the
  // background at 0, plus Gaussian noise of this sd (a fixed seed), as f32,
  // with intensity targets (thesis chapter 5).
  double grey_noise = -1;
  // Experiments only: change the parameters before they are set; called
  // after every step with its number (1-based).
  std::function<void(ffseg_params&)> tune;
  std::function<void(int, ffseg_engine*, const ffseg_step_info&)> after_step;
};

DeformRunResult run_deform(const Phantom& ph, const DeformRunOptions& o);

}  // namespace ffseg_test
