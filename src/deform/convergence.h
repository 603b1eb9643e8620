// When an object is at rest: each object's own record of how it moves, step by
// step, and the rule that turns it into "converged". Read by the engine for
// every object, however many there are (the step report only shows the first
// FFSEG_REPORT_OBJECTS of them and is never read back).
#pragma once
#include <cstdint>

namespace ffseg {

// What decides rest; filled from the parameters at each step.
struct ConvergenceRule {
  double convergence_mm = 0.05;
  // Binary targets polish after their first rest (a few diffusion rounds
  // instead of many) and converge at the second; grey-level targets move to
  // partial-volume boundaries for at most partial_volume_steps steps instead.
  bool binary = true;
  uint32_t partial_volume_steps = 0;
  // Grey-level targets re-space their loops until the first rest
  // (Params::grey_respacing): their rest is then judged as binary targets'.
  bool grey_respacing = false;
  // The object's boundary is in view of the box around its sphere
  // (IntensityModel::boundary_in_view()): growing freely, it rests slowly.
  bool boundary_in_view = false;
};

// How one step moved an object's mesh (stages.cpp's tally).
struct StepMotion {
  double mean_mm = 0;    // mean vertex displacement
  uint32_t moving = 0;   // vertices that moved by more than moving_threshold()
  // Mean displacement across the surface (the component along each vertex's
  // normal): sliding within the surface, as the binary targets' loop
  // re-spacing makes it, does not count.
  double normal_mm = 0;
  // The fronts: the vertices whose target lies more than a voxel away (the
  // mesh has not reached the boundary there), their mean advance toward it;
  // 0 when there are none.
  double front_mm = 0;
};

class Convergence {
 public:
  // Move again from where the mesh is (new parameters or volume).
  void restart() {
    converged_ = false;
    stalled_ = false;
    releasing_ = false;
    released_ = false;
    refining_ = false;
    refine_steps_ = 0;
    creep_ = 0;
  }
  // A new sphere: also forget the polishing phase.
  void reset() {
    restart();
    polish_ = false;
  }

  bool converged() const { return converged_; }
  // Binary targets: came to rest once, now polishing (fewer diffusion rounds).
  bool polishing() const { return polish_; }
  // Grey-level targets: came to rest once, now on partial-volume boundaries.
  bool refining() const { return refining_; }
  // Grey-level targets: the first rest was a stall; the loops are re-spaced
  // until the object rests again (a way out of the jam, see stalled()).
  bool releasing() const { return releasing_; }
  // Whether this step re-spaces the loops (loop_spacing.h): binary targets
  // until their first rest, grey levels while releasing a stall or, with
  // grey_respacing, until their first rest too. The motion across the
  // surface and at the fronts (StepMotion) is then what decides the rest.
  bool respacing(const ConvergenceRule& r) const {
    return r.binary ? !polish_ : releasing_ || (r.grey_respacing && !refining_ && !converged_);
  }

  // A vertex that moves more than this counts as moving (StepMotion::moving).
  double moving_threshold(const ConvergenceRule& r) const;
  // Records one step's motion and advances the phases. Returns converged().
  // net_far_share: (vertices with targets more than a voxel outward - those
  // more than a voxel inward) / nv, for stalled().
  bool record(const ConvergenceRule& r, const StepMotion& m, uint32_t nv, double net_far_share = 0.0);
  // The first rest was no rest at a boundary but a stall: the mesh stood
  // still while more than kStallShare of its vertices, on balance, still
  // pointed more than a voxel beyond it on one side (the guard, the fold
  // prevention or a creeping mean held it; a mesh resting at a noisy
  // boundary has far targets on both sides that cancel). Grey-level targets
  // first try a way out (releasing()) and are judged again at the next
  // rest. A stall still counts as converged (it no longer steps); the
  // engine flags it.
  bool stalled() const { return stalled_; }

 private:
  bool polish_ = false;
  bool refining_ = false;
  uint32_t refine_steps_ = 0;
  uint32_t creep_ = 0;
  bool converged_ = false;
  bool stalled_ = false;
  bool releasing_ = false;
  bool released_ = false;
};

}  // namespace ffseg
