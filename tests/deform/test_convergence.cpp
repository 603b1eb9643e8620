// Convergence (src/deform/convergence.h): binary targets come to rest (the
// surface still, no front advancing), polish,
// and converge at the second rest; grey-level targets refine for at most
// partial_volume_steps steps after the first rest; restart and reset.
#include <doctest/doctest.h>

#include "convergence.h"

using ffseg::Convergence;
using ffseg::ConvergenceRule;
using ffseg::StepMotion;

namespace {

ConvergenceRule binary_rule() {
  ConvergenceRule r;
  r.convergence_mm = 0.05;
  r.binary = true;
  r.partial_volume_steps = 4;  // ignored for binary targets
  return r;
}

ConvergenceRule grey_rule(uint32_t pv_steps) {
  ConvergenceRule r;
  r.convergence_mm = 0.05;
  r.binary = false;
  r.partial_volume_steps = pv_steps;
  return r;
}

// A step's motion: mean, moving, across the surface, the fronts' advance.
StepMotion motion(double mean, uint32_t moving, double normal, double front) {
  StepMotion m;
  m.mean_mm = mean;
  m.moving = moving;
  m.normal_mm = normal;
  m.front_mm = front;
  return m;
}

// Grey-level targets read the mean (and the count) only.
StepMotion grey(double mean, uint32_t moving) { return motion(mean, moving, mean, 0.0); }

}  // namespace

TEST_CASE("convergence, binary: rest when the surface stands still and no front advances, polish, rest again") {
  const ConvergenceRule r = binary_rule();
  const uint32_t nv = 1000;
  Convergence c;
  CHECK_FALSE(c.converged());
  CHECK_FALSE(c.polishing());
  CHECK(c.moving_threshold(r) == doctest::Approx(0.05));
  // Moving across the surface: nothing changes.
  CHECK_FALSE(c.record(r, motion(0.2, 500, 0.2, 0.0), nv));
  CHECK_FALSE(c.polishing());
  // The surface stands still but a front advances (a tube's tip): not at rest.
  CHECK_FALSE(c.record(r, motion(0.1, 5, 0.003, 0.3), nv));
  CHECK_FALSE(c.polishing());
  // Across the surface exactly at convergence_mm is not below it, nor a
  // front's advance.
  CHECK_FALSE(c.record(r, motion(0.05, 0, 0.05, 0.0), nv));
  CHECK_FALSE(c.record(r, motion(0.01, 0, 0.01, 0.05), nv));
  CHECK_FALSE(c.polishing());
  // First rest: the vertices still slide (mean 0.1 mm, all of them moving)
  // but not across the surface, and the fronts stand: polishing.
  CHECK_FALSE(c.record(r, motion(0.1, 1000, 0.02, 0.01), nv));
  CHECK(c.polishing());
  CHECK_FALSE(c.refining());
  CHECK(c.moving_threshold(r) == doctest::Approx(0.75 * 0.05));
  // Polishing: the vertices' own motion decides. A small mean with more
  // than 1 % of them moving is no rest, nor a large one.
  CHECK_FALSE(c.record(r, motion(0.01, 11, 0.0, 0.0), nv));
  CHECK_FALSE(c.record(r, motion(0.3, 300, 0.3, 0.0), nv));
  CHECK(c.polishing());
  // Second rest (10 of 1000 moving is within 1 %): converged, and it stays so.
  CHECK(c.record(r, motion(0.049, 10, 0.049, 0.0), nv));
  CHECK(c.converged());
  // restart(): moves again, but keeps having polished: the next rest converges.
  c.restart();
  CHECK_FALSE(c.converged());
  CHECK(c.polishing());
  CHECK(c.record(r, motion(0.01, 0, 0.01, 0.0), nv));
  // reset() (a new sphere): polishing forgotten, two rests needed again.
  c.reset();
  CHECK_FALSE(c.polishing());
  CHECK_FALSE(c.record(r, motion(0.01, 0, 0.01, 0.0), nv));
  CHECK(c.record(r, motion(0.01, 0, 0.01, 0.0), nv));
}

TEST_CASE("convergence, grey-level: refining after the first rest, ended by a rest or the step budget") {
  const uint32_t nv = 1000;
  SUBCASE("the budget ends refining") {
    const ConvergenceRule r = grey_rule(3);
    Convergence c;
    // The moving count does not matter for grey-level targets.
    CHECK_FALSE(c.record(r, grey(0.01, 900), nv));
    CHECK(c.refining());
    CHECK_FALSE(c.polishing());
    CHECK(c.moving_threshold(r) == doctest::Approx(0.05));  // no polishing factor
    CHECK_FALSE(c.record(r, grey(0.4, 900), nv));  // refine step 1
    CHECK_FALSE(c.record(r, grey(0.4, 900), nv));  // 2
    CHECK(c.record(r, grey(0.4, 900), nv));        // 3 = partial_volume_steps
    CHECK(c.converged());
  }
  SUBCASE("a rest ends refining") {
    const ConvergenceRule r = grey_rule(10);
    Convergence c;
    CHECK_FALSE(c.record(r, grey(0.5, 0), nv));
    CHECK_FALSE(c.refining());
    CHECK_FALSE(c.record(r, grey(0.04, 0), nv));
    CHECK(c.refining());
    CHECK_FALSE(c.record(r, grey(0.2, 0), nv));
    CHECK(c.record(r, grey(0.02, 0), nv));
  }
  SUBCASE("no partial-volume steps: the first rest converges") {
    const ConvergenceRule r = grey_rule(0);
    Convergence c;
    CHECK_FALSE(c.record(r, grey(0.06, 0), nv));
    CHECK(c.record(r, grey(0.04, 999), nv));
    CHECK_FALSE(c.refining());
  }
  SUBCASE("restart forgets the refining phase and its steps") {
    const ConvergenceRule r = grey_rule(2);
    Convergence c;
    CHECK_FALSE(c.record(r, grey(0.01, 0), nv));  // refining
    CHECK_FALSE(c.record(r, grey(0.5, 0), nv));   // refine step 1
    c.restart();
    CHECK_FALSE(c.refining());
    CHECK_FALSE(c.converged());
    CHECK_FALSE(c.record(r, grey(0.01, 0), nv));  // refining again, from step 0
    CHECK_FALSE(c.record(r, grey(0.5, 0), nv));   // 1
    CHECK(c.record(r, grey(0.5, 0), nv));         // 2
  }
}

TEST_CASE("convergence, grey-level: a creep below twice the threshold for three steps is a rest; binary targets ignore it") {
  const uint32_t nv = 1000;
  {
    const ConvergenceRule r = grey_rule(0);
    Convergence c;
    CHECK_FALSE(c.record(r, grey(0.06, 10), nv));
    CHECK_FALSE(c.record(r, grey(0.09, 10), nv));
    CHECK_FALSE(c.record(r, grey(0.2, 10), nv));  // a real move breaks the run
    CHECK_FALSE(c.record(r, grey(0.06, 10), nv));
    CHECK_FALSE(c.record(r, grey(0.07, 10), nv));
    CHECK(c.record(r, grey(0.06, 10), nv));  // the third in a row
  }
  {
    const ConvergenceRule r = grey_rule(2);  // the creep's rest starts the partial-volume steps
    Convergence c;
    for (int k = 0; k < 3; ++k) CHECK_FALSE(c.record(r, grey(0.07, 10), nv));
    CHECK(c.refining());
    CHECK_FALSE(c.record(r, grey(0.07, 10), nv));  // counted afresh: 1 of the 2 steps
    CHECK(c.record(r, grey(0.07, 10), nv));        // the budget is spent
  }
  {
    const ConvergenceRule r = binary_rule();
    Convergence c;
    for (int k = 0; k < 10; ++k) CHECK_FALSE(c.record(r, grey(0.07, 5), nv));
    CHECK_FALSE(c.polishing());
  }
  {  // restart forgets the run
    const ConvergenceRule r = grey_rule(0);
    Convergence c;
    CHECK_FALSE(c.record(r, grey(0.07, 10), nv));
    CHECK_FALSE(c.record(r, grey(0.07, 10), nv));
    c.restart();
    CHECK_FALSE(c.record(r, grey(0.07, 10), nv));
    CHECK_FALSE(c.record(r, grey(0.07, 10), nv));
    CHECK(c.record(r, grey(0.07, 10), nv));
  }
}

TEST_CASE("convergence, grey-level: a stall at the first rest re-spaces the loops until the next rest, then is judged again") {
  const uint32_t nv = 1000;
  SUBCASE("still stalled after the release: converged and flagged") {
    const ConvergenceRule r = grey_rule(0);
    Convergence c;
    CHECK_FALSE(c.respacing(r));
    CHECK_FALSE(c.record(r, grey(0.5, 900), nv, 0.2));
    CHECK_FALSE(c.releasing());
    // At rest with a fifth of the vertices, on balance, pointing outward
    // beyond a voxel: a stall, released rather than converged.
    CHECK_FALSE(c.record(r, grey(0.01, 0), nv, 0.2));
    CHECK(c.releasing());
    CHECK(c.respacing(r));
    CHECK_FALSE(c.stalled());
    // Releasing: the vertices slide (a mean of 1 mm), the surface creeps
    // (0.07 mm, below the creep threshold, which does not apply here).
    for (int k = 0; k < 5; ++k) CHECK_FALSE(c.record(r, motion(1.0, 900, 0.07, 0.0), nv, 0.2));
    // A front still advancing: no rest either.
    CHECK_FALSE(c.record(r, motion(1.0, 900, 0.01, 0.2), nv, 0.2));
    // The surface still, no front: the rest ends the release; still stalled.
    CHECK(c.record(r, motion(0.3, 900, 0.01, -0.1), nv, 0.2));
    CHECK(c.stalled());
    CHECK_FALSE(c.releasing());
    CHECK_FALSE(c.respacing(r));
  }
  SUBCASE("released: then the partial-volume steps, and no second release") {
    const ConvergenceRule r = grey_rule(1);
    Convergence c;
    CHECK_FALSE(c.record(r, grey(0.01, 0), nv, -0.15));  // inward stall
    CHECK(c.releasing());
    CHECK_FALSE(c.record(r, motion(0.2, 0, 0.01, 0.0), nv, 0.05));
    CHECK_FALSE(c.stalled());
    CHECK(c.refining());
    CHECK(c.record(r, grey(0.4, 0), nv, 0.3));  // the one partial-volume step
    CHECK_FALSE(c.stalled());                   // judged at the rests only
  }
  SUBCASE("binary targets never release (they re-space until their first rest anyway)") {
    const ConvergenceRule r = binary_rule();
    Convergence c;
    CHECK(c.respacing(r));
    CHECK_FALSE(c.record(r, motion(0.3, 0, 0.01, 0.0), nv, 0.2));
    CHECK(c.stalled());
    CHECK_FALSE(c.releasing());
    CHECK(c.polishing());
    CHECK_FALSE(c.respacing(r));
  }
}

TEST_CASE("convergence, grey-level growing freely: a tenth of the threshold where its boundary is in view, else the threshold") {
  const uint32_t nv = 1000;
  ConvergenceRule r = grey_rule(0);
  r.grey_respacing = true;
  // The surface and its fronts move 0.02 mm a step: at rest by the threshold
  // (0.05), not by a tenth of it.
  const StepMotion slow = motion(0.3, 900, 0.02, 0.02);
  {
    r.boundary_in_view = true;  // a tube of its own contrast: its tip advances slowly
    Convergence c;
    CHECK(c.respacing(r));
    for (int k = 0; k < 5; ++k) CHECK_FALSE(c.record(r, slow, nv));
    CHECK(c.record(r, motion(0.3, 900, 0.004, 0.004), nv));
  }
  {
    r.boundary_in_view = false;  // re-spaced by request (a finer run refining a coarse one)
    Convergence c;
    CHECK(c.respacing(r));
    CHECK(c.record(r, slow, nv));
  }
}
