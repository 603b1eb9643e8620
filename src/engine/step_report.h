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

// Why an object's result is no segmentation (ffseg.h FFSEG_OBJECT_*).
enum ObjectFlag : uint32_t {
  kObjectNoBoundary = 1,  // no vertex found a boundary in any step since the object was placed
  kObjectFillsGrid = 2,   // more than kFillsGridFraction of the grid's voxels lie inside its mesh
  kObjectStalled = 4,     // came to rest held, targets still beyond it (Convergence::stalled())
};
// An organ is cut out of its scan with background around it: a mesh holding
// this much of the grid has swallowed the background. A sphere inscribed in
// the grid's box holds about 52% of it, so a tightly cropped round organ
// stays below.
constexpr double kFillsGridFraction = 0.8;

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
  uint32_t object_flags[kReportObjects] = {};
  uint32_t flags_all = 0;  // every placed object's flags, or-ed
  uint32_t guard_held[kReportObjects] = {};   // vertices the step guard held to less than half their update
  uint32_t far_outward[kReportObjects] = {};  // vertices with a target more than a voxel outward
  uint32_t far_inward[kReportObjects] = {};   // ... and inward
  uint32_t respaced[kReportObjects] = {};     // 1: the mesh re-spaced its contour loops this step
};

}  // namespace ffseg
