// What one step reports: per stage times, and per object (the first
// kReportObjects of them) how it moved. Written by the step, never read back
// by the engine.
#pragma once
#include <cstdint>

namespace ffseg {

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
  kStageRegions,  // several objects: the bounding regions (thesis 6.2)
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
  // Vertices that moved beyond Convergence::moving_threshold() this step.
  uint32_t moving[kReportObjects] = {};
  uint64_t stage_us[kStageCount] = {};
};

}  // namespace ffseg
