#include "convergence.h"

namespace ffseg {

namespace {

// Binary targets come to rest when their surface stands still and no front
// advances: the mean displacement along the vertex normals is below
// convergence_mm, and so is the fronts' mean advance toward their targets
// (StepMotion). Not the vertices' own displacement: the loops' re-spacing
// slides them within the surface, on a folded one for good (the Colin27
// brain mask at n = 49: 0.07-0.10 mm a step, of it 0.013-0.015 mm across
// the surface). Not the mean across the surface alone either: along a tube
// only the front moves, a few vertices of thousands, while their advance
// stays at 0.14-0.65 mm a step (BENCHMARKS.md section 12); the fronts'
// advance is also what keeps the cup's cavity filling.
// Then the mesh polishes (fewer diffusion rounds, no re-spacing:
// stages.cpp) and fits sharp features with small motions of a few vertices,
// where a mean alone stops too soon: it has converged when the mean
// displacement is below convergence_mm and at most kMovingShare of the
// vertices still move by more than kPolishStillFactor times it (the cup's
// cavity corners fill a little each step: n = 21, alpha 0.3 stopped at Dice
// 0.963 with a factor of 4, reaches 0.97 with this one). Grey-level targets
// flicker between neighbouring voxel decisions: a few percent of the
// vertices keep moving by that much for good (Colin27 putamen: 11 more
// steps, none changing Dice by more than noise), so there the mean alone
// decides.
constexpr double kPolishStillFactor = 0.75;
constexpr double kMovingShare = 0.01;
// Grey-level targets also rest once the mean displacement has stayed below
// kCreepFactor times convergence_mm for kCreepSteps steps in a row: such a
// mesh is no longer approaching a boundary but creeping along flickering
// voxel decisions, and it creeps outward (Colin27 thalamus L: 15 steps at
// 0.055-0.067 mm before the mean fell below 0.05, 33 steps in all, Dice
// 0.563; with the rule 17 steps, 0.597). Chosen on the right-hemisphere
// structures (issue 19): mean Dice 0.545 -> 0.550 at (2, 3), 0.549 at
// (2, 5), 0.545 at (1.5, 3..8); held out, the left went 0.537 -> 0.541.
constexpr double kCreepFactor = 2.0;
constexpr uint32_t kCreepSteps = 3;
// A stall: at the first rest, more than this share of the vertices on
// balance still has a target beyond a voxel on one side. Between the largest
// share of a mesh at rest in Colin27's eight structures (0.092, the
// hippocampus R) and the jammed n = 49 liver of the 1 mm CT (0.27; at n = 12
// it rests at 0.095, where the model ends it); none of the shared CT's
// choosing-set organs at 3 mm comes near it (at most 0.088, the gallbladder's
// leak).
constexpr double kStallShare = 0.1;
// A mesh growing freely where its boundary is in view grows at a
// few front vertices, whose advance the diffusion averages with their
// resting neighbours': at convergence_mm it came to rest while still taking
// in 1.5% of its volume a step (Colin27's right lateral ventricle from its
// frontal horn: 41 steps, 4.9 ml of 8.0; issue 29's grey tube at 78% of its
// length). Its boundary is in view (no flicker to outlast, no neighbour of
// its grey level to creep into), so it rests only when its surface and
// fronts move less than a tenth of convergence_mm. On the left ventricle's
// six placements (the choosing set) mean Dice 0.813 at 1, 0.823 at 0.6,
// 0.825 at 0.4, 0.828 at 0.2, 0.827 at 0.1: a tie below 0.4, which the grey
// tube at 1 mm decides (0.2: 92% of its length, Dice 0.845; 0.1: 94%,
// 0.852). The right ventricle's four, seen at the same time: 0.742, 0.747,
// 0.777, 0.787, 0.843 (BENCHMARKS.md section 12). A mesh re-spaced where
// its boundary is not in view (grey_respacing 1; the CLI's finer run
// refining a coarse one) has neighbours of its grey level to creep into:
// it rests at convergence_mm (at a tenth, the 3 mm CT's liver crept on for
// 200 steps to 1,199 ml of 1,123 instead of resting at 1,147 ml).
constexpr double kFreeGrowthRestFactor = 0.1;

}  // namespace

double Convergence::moving_threshold(const ConvergenceRule& r) const {
  return (polish_ ? kPolishStillFactor : 1.0) * r.convergence_mm;
}

bool Convergence::record(const ConvergenceRule& r, const StepMotion& m, uint32_t nv, double net_far_share) {
  const double c = r.convergence_mm;
  bool rest = m.mean_mm < c;
  if (r.binary) {
    rest = polish_ ? rest && double(m.moving) <= kMovingShare * nv : m.normal_mm < c && m.front_mm < c;
  } else if (respacing(r)) {
    // Re-spaced: the surface and its fronts, as for binary targets. No creep
    // rule here: it ended the right kidney's release after 5 steps (0.697
    // against 0.763 after 31).
    const double cr = r.grey_respacing && r.boundary_in_view ? kFreeGrowthRestFactor * c : c;
    rest = m.normal_mm < cr && m.front_mm < cr;
  } else {
    creep_ = m.mean_mm < kCreepFactor * c ? creep_ + 1 : 0;
    if (creep_ >= kCreepSteps) rest = true;
  }
  // The first rest decides whether it is a stall (the later ones polish or
  // refine a boundary already met), and so does the rest that ends a
  // release.
  const bool judged = rest && !polish_ && !refining_;
  if (judged) stalled_ = net_far_share > kStallShare || -net_far_share > kStallShare;
  // A grey-level stall: the guard and the fold prevention hold a creased
  // patch whose vertices the smoothness terms cannot spread (the right
  // kidney at 3 mm: slivers of 0.4 mm where the mesh's median edge is 3.3
  // mm, BENCHMARKS.md section 12). The loops' re-spacing spreads them; it
  // is not the default for grey levels because it also carries a mesh
  // through any gap the model leaves open (BENCHMARKS.md section 12), so it
  // runs only once the mesh has stalled, until it rests again.
  if (!r.binary && judged) {
    if (releasing_) {
      releasing_ = false;
      released_ = true;
    } else if (stalled_ && !released_) {
      releasing_ = true;
      stalled_ = false;
      creep_ = 0;
      return converged_;
    }
  }
  // With binary targets, the first time an object comes to rest it goes on
  // polishing (engine.cpp's polish_rounds); it has converged when it comes to
  // rest again. Grey-level targets are noisy samples of the boundary: with
  // little smoothing the mesh follows the noise (right-hemisphere Colin27 mean
  // Dice 0.511 -> 0.492 when polishing), so they do not polish; at the first
  // rest they move their boundaries to the partial-volume level for a few
  // steps instead (with it from the first step, the right-hemisphere Colin27
  // mean Dice fell 0.536 -> 0.501, the thalamus leaking into the midbrain;
  // after the first rest it rose to 0.550).
  if (r.binary) {
    if (rest && polish_) converged_ = true;
    if (rest) polish_ = true;
  } else if (refining_) {
    // Done when the object rests again or the steps are spent.
    if (rest || ++refine_steps_ >= r.partial_volume_steps) converged_ = true;
  } else if (rest && r.partial_volume_steps > 0) {
    refining_ = true;
    creep_ = 0;  // the partial-volume steps get their own count
  } else if (rest) {
    converged_ = true;
  }
  return converged_;
}

}  // namespace ffseg
