// `ffseg segment --seed-check`: how much the result depends on where the
// sphere was put (issue 19, stability). On Colin27 the deep nuclei agree
// with themselves from a 0.6x or 1.5x sphere, or one moved by 1 mm, at
// pairwise Dice 0.56-0.98 (BENCHMARKS.md section 4): a contour from a
// knife-edge seed looks like any other. The check segments again from the
// five perturbations of that protocol (every sphere at once: radius x0.6,
// x1.5; centre +1 mm along world x, y, z), with the same request otherwise,
// and compares each object's mask with the result: a user sees how far the
// contour would move under a hand's placement error, and a warning when it
// would move more than kSeedCheckFloor allows.
#ifndef FFSEG_CLI_SEED_CHECK_H
#define FFSEG_CLI_SEED_CHECK_H

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "report_json.h"
#include "segment_options.h"

namespace ffseg_cli {

struct SeedVariant {
  const char* name;      // as report.json names it
  double radius_scale;   // of every sphere
  double shift_mm[3];    // world (RAS) mm, added to every centre
};
constexpr uint32_t kSeedVariants = 5;
extern const SeedVariant kSeedVariant[kSeedVariants];
// Issue 19's floor for a result that does not depend on its seed.
constexpr double kSeedCheckFloor = 0.85;

// --consensus: the same six runs (the result and the five perturbed ones)
// vote; a voxel is in an object's consensus when it lies inside that
// object's mesh in at least this share of the runs that ran (5 of 6). A leak
// that one placement triggers and the next does not is voted out, and so is
// a jammed small seed's shortfall. Chosen on the right-hemisphere Colin27
// structures (BENCHMARKS.md section 4, 2026-12-05): 5 of 6 gave their worst
// pair 0.704 against 0.686 at 4 and 0.620 at 3.
constexpr double kConsensusShare = 5.0 / 6.0;

// rq with every sphere perturbed as v says: centres (world mm, as the run
// placed them) moved, radii scaled; the perturbed runs print nothing.
SegmentRequest perturbed_request(const SegmentRequest& rq, const std::vector<std::array<double, 3>>& centres_mm,
                                 const SeedVariant& v);

// Dice of two 0/1 masks of one grid (1 when both are empty).
double mask_dice(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b);

struct SeedCheck {
  uint32_t runs = 0;  // the result's and the perturbed runs that ran
  // dice[k][v]: object k's mask from variant v against the result's; a
  // negative entry: variant v could not be run (failed[v] says why).
  std::vector<std::array<double, kSeedVariants>> dice;
  std::array<std::string, kSeedVariants> failed;
  double lowest(uint32_t k) const;  // over the variants that ran; 1 when none did
};

// Runs every variant through `segment` (one run of the request: the masks
// of its objects, in order; may throw CliError, which marks the variant
// failed, except an interrupt, which goes on up) and compares the masks
// with `result` (the masks of the run being checked). votes (may be null):
// per object and voxel, in how many runs (the result's included) the voxel
// was inside the object. The variants run on `jobs` threads at once (each
// run is its own engine in its own workspace, so memory grows with jobs);
// the figures do not depend on jobs or on the order the runs finish in.
SeedCheck check_seeds(const SegmentRequest& rq, const std::vector<std::array<double, 3>>& centres_mm,
                      const std::vector<std::vector<uint8_t>>& result,
                      const std::function<std::vector<std::vector<uint8_t>>(const SegmentRequest&)>& segment,
                      std::vector<std::vector<uint8_t>>* votes = nullptr, uint32_t jobs = 1);

// Each object's consensus mask from the votes of `runs` runs (kConsensusShare),
// every voxel given to the first object that holds it, as in labels.nii.gz.
std::vector<std::vector<uint8_t>> consensus_masks(const std::vector<std::vector<uint8_t>>& votes, uint32_t runs);

// report.json's "seed_check": the variants and, per object, its Dice against each.
ffseg_tools::Json seed_check_json(const SeedCheck& sc, const std::vector<std::string>& names);

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_SEED_CHECK_H
