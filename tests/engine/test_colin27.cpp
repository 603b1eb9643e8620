// Chapter 5 on real data: the Colin27 T1 MRI against its AAL labels, through
// the C API. Protocol (PEERS.md): the sphere's centre is the label voxel
// farthest from the label's border, its radius half that distance.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ffseg.h"
#include "metrics.h"
#include "nifti.h"
#include "support/colin27_run.h"
#include "support/mesh_check.h"
#include "support/phantoms.h"
#include "support/stored_variants.h"
#include "test_util.h"

using namespace ffseg_test;

namespace {

// One object on a binary volume (img: its non-zero voxels), from the sphere
// (c, r mm) at mesh resolution n, stepped to rest or max_steps with every
// step watched for crossings and flips; its rasterised mask against truth.
struct BinaryRun {
  ffseg_tools::SegMetrics m{};
  int steps = 0;                          // taken, the converging one included
  bool at_rest = false;                   // the last step returned CONVERGED or DEGENERATE
  size_t intersections = 0, flips = 0;    // worst over the steps
};

BinaryRun run_binary(const ffseg_tools::NiftiImage& img, const std::vector<uint8_t>& truth, uint32_t n,
                     const double c[3], double r, int max_steps) {
  EngineBox eb(1, n);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_BINARY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume v = volume_of(img);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  ffseg_test::MeshWatch watch;
  BinaryRun b;
  while (b.steps < max_steps) {
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    REQUIRE(st >= 0);
    ++b.steps;
    REQUIRE(watch.look(eb.e, 0));
    if (st == FFSEG_CONVERGED || st == FFSEG_DEGENERATE) {  // at rest
      b.at_rest = true;
      break;
    }
  }
  std::vector<uint8_t> mask(truth.size());
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  b.m = ffseg_tools::compare_masks(mask.data(), truth.data(), img.dims, img.spacing);
  b.intersections = watch.intersections;
  b.flips = watch.flips;
  return b;
}

}  // namespace

TEST_CASE("chapter 4 on a real shape: the Colin27 brain mask (ch2bet), n = 49, Dice >= 0.93, at rest, never self-intersecting") {
  ffseg_tools::NiftiImage bet;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file("/usr/share/mricron/templates/ch2bet.nii.gz", &bet, &err), err);
  const size_t N = bet.data.size();
  std::vector<uint8_t> truth(N);
  for (size_t i = 0; i < N; ++i) truth[i] = bet.data[i] != 0;
  // A sphere around the brain: the mask's bounding-box centre, radius to its
  // farthest corner.
  int lo[3] = {1 << 30, 1 << 30, 1 << 30}, hi[3] = {-1, -1, -1};
  for (int k = 0; k < bet.dims[2]; ++k)
    for (int j = 0; j < bet.dims[1]; ++j)
      for (int i = 0; i < bet.dims[0]; ++i)
        if (truth[size_t(i) + size_t(bet.dims[0]) * (size_t(j) + size_t(bet.dims[1]) * size_t(k))]) {
          const int q[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], q[a]);
            hi[a] = std::max(hi[a], q[a]);
          }
        }
  double c[3], ci[3], r2 = 0;
  for (int a = 0; a < 3; ++a) ci[a] = 0.5 * (lo[a] + hi[a]);
  for (int r = 0; r < 3; ++r)
    c[r] = bet.index_to_world[4 * r] * ci[0] + bet.index_to_world[4 * r + 1] * ci[1] + bet.index_to_world[4 * r + 2] * ci[2] +
           bet.index_to_world[4 * r + 3];
  for (int a = 0; a < 3; ++a) r2 += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]) * bet.spacing[a] * bet.spacing[a];
  const double radius = std::sqrt(r2) + 2.0;

  const BinaryRun b = run_binary(bet, truth, 49, c, radius, 150);
  std::printf("ch2bet brain mask, n=49: Dice %.4f ASSD %.2f mm HD95 %.2f mm, %d steps, worst intersections %zu, flips %zu\n",
              b.m.dice, b.m.assd_mm, b.m.hd95_mm, b.steps, b.intersections, b.flips);
  CHECK(b.m.dice >= 0.93);
  // A folded surface: the loops' re-spacing slides the vertices within it
  // for good, which must not keep the mesh from resting (convergence.cpp).
  CHECK(b.at_rest);
  CHECK(b.intersections == 0);
  CHECK(b.flips == 0);
}

// The mesh's share of issue 19's gap: the eight protocol structures grown
// from their protocol spheres at n = 12, as the grey-level runs are, but
// with the AAL label itself as a binary target (perfect evidence). What the
// mesh loses here (resolution, regularisation, the guard, rasterisation) is
// all it can lose; the grey-level runs' mean 0.54 lies far below it
// (BENCHMARKS.md section 4, 2026-12-05; scripts/mesh_ceiling.py gives the
// same table through the CLI).
TEST_CASE("chapter 4 on the Colin27 protocol structures: the label as its own target, n = 12, Dice >= 0.8 each, mean >= 0.9") {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  REQUIRE(aal.voxel_type == FFSEG_U8);
  const size_t N = aal.data.size();
  const int labels[8] = {73, 74, 77, 78, 71, 72, 37, 38};
  double sum = 0;
  for (int label : labels) {
    CAPTURE(label);
    std::vector<uint8_t> truth(N);
    for (size_t i = 0; i < N; ++i) truth[i] = aal.data[i] == label;
    double c[3], r = 0;
    protocol_sphere(t1, truth, c, &r);
    ffseg_tools::NiftiImage target = aal;
    target.data = truth;
    const BinaryRun b = run_binary(target, truth, 12, c, r, 200);
    std::printf("AAL %d as its own binary target, n=12: Dice %.4f ASSD %.2f mm, %d steps\n", label, b.m.dice,
                b.m.assd_mm, b.steps);
    CHECK(b.m.dice >= 0.8);
    CHECK(b.intersections == 0);
    CHECK(b.flips == 0);
    sum += b.m.dice;
  }
  CHECK(sum / 8 >= 0.9);
}

TEST_CASE("chapter 5 on Colin27: eight AAL structures from the protocol sphere, floors on Dice and ASSD") {
  // Floors guard today's measured result (mesh n = 12, default parameters)
  // minus a margin; they are below what PEERS.md asks of ffseg for the caudate.
  // Defaults (Gamma = 0.2, scene competitors) were chosen on the right-hemisphere
  // structures (74, 78, 72, 38) only; 73, 77, 71, 37 are held out (issue #4).
  // The step guard's local fallback restarting every share at 1 (needed by the
  // cup) left the right-side mean Dice at 0.507 and moved the held-out side:
  // caudate L 0.47 -> 0.63, putamen L 0.43 -> 0.35, hippocampus L 0.55 -> 0.50.
  // Automatic diffusion rounds (20 (n/33)^2: 3 at n = 12, from the cup) moved
  // the right-side mean to 0.511; held out: putamen L 0.40, thalamus L 0.58,
  // caudate L 0.62, hippocampus L 0.55. Convergence on the mean displacement
  // alone for grey levels (putamen L 33 -> 21 steps): right-side mean 0.515;
  // held out: putamen L 0.41, thalamus L 0.60, caudate L 0.62, hippocampus L 0.55.
  // Even diffusion rounds (4 at n = 12) and the tension-only uniform term
  // (smooth meshes: median bend 3-7 degrees instead of 11-16, the guard 17-24 ms
  // instead of 124-212 ms per structure): right-side mean 0.536; held out:
  // putamen L 0.41, thalamus L 0.61, caudate L 0.60, hippocampus L 0.50. Over
  // six perturbed spheres (FFSEG_JITTER=1) both means stay as they were (right
  // 0.512, left 0.543 against 0.547).
  // Partial-volume boundaries for 4 steps after the first rest (issue #4):
  // right-side mean 0.550 (0.522 over six spheres); held out: putamen L 0.40,
  // thalamus L 0.60, caudate L 0.67, hippocampus L 0.50.
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  struct Case {
    int label;
    const char* name;
    double dice_floor, assd_ceiling;
  };
  // Measured (Dice / ASSD mm): 0.399 / 4.16, 0.480 / 3.48, 0.601 / 2.73,
  // 0.609 / 2.46, 0.672 / 1.97, 0.630 / 2.40, 0.499 / 3.61, 0.483 / 3.77.
  // The caudate L floor was the best classic method's Dice (PEERS.md: ITK's
  // threshold level set, 0.649), the goal of issue #4.
  // Statistics from the search range around the seed's centre, rho 0.04
  // (issue 19: seed-size invariance; rho chosen on the right side): 0.412 /
  // 4.29, 0.511 / 3.16, 0.563 / 3.19, 0.569 / 2.61, 0.630 / 2.29, 0.621 /
  // 2.36, 0.544 / 3.38, 0.478 / 4.29. The caudate L is now below the classic
  // 0.649 (over six perturbed seeds too: 0.633), the thalami lower, the
  // hippocampus L higher. With grey-level creep counted as rest
  // (convergence.cpp): 0.412 / 4.29, 0.531 / 3.15, 0.597 / 2.65, 0.569 /
  // 2.61, 0.610 / 2.52, 0.623 / 2.38, 0.544 / 3.38, 0.478 / 4.29. With the
  // statistics and samples independent of the storage (box_lattice.h, sorted
  // samples, one g table for every voxel type): 0.377 / 4.56, 0.549 / 2.98,
  // 0.585 / 2.73, 0.566 / 2.67, 0.653 / 2.21, 0.623 / 2.49, 0.543 / 3.38,
  // 0.455 / 4.41 (the caudate L back above the classic 0.649; the hippocampus
  // R's ceiling raised from 4.4 to 4.6 and its floor and the putamen L's lowered
  // by 0.02 to keep a margin).
  const Case cases[] = {{73, "putamen L", 0.35, 4.8},    {74, "putamen R", 0.45, 4.0},
                        {77, "thalamus L", 0.53, 3.6},   {78, "thalamus R", 0.54, 3.0},
                        {71, "caudate L", 0.58, 2.7},    {72, "caudate R", 0.59, 2.9},
                        {37, "hippocampus L", 0.47, 4.2}, {38, "hippocampus R", 0.43, 4.6}};
  std::printf("| structure | AAL | Dice | VOE | ASSD mm | HD95 mm | steps | ms |\n|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    CAPTURE(c.name);
    StructureRunOptions ro;
    ro.check_mesh = true;
    const StructureResult r = segment_structure(t1, aal, c.label, c.name, 12, 100, ro);
    std::printf("| %s | %d | %.3f | %.3f | %.2f | %.2f | %d | %.0f |\n", r.name, r.label, r.m.dice, r.m.voe, r.m.assd_mm,
                r.m.hd95_mm, r.steps, r.ms);
    CHECK(r.m.dice >= c.dice_floor);
    CHECK(r.m.assd_mm <= c.assd_ceiling);
    CHECK(r.intersections == 0);  // after every step
    CHECK(r.flips == 0);
  }
}

TEST_CASE("chapter 5 on Colin27: partial-volume steps come after the first rest, at most partial_volume_steps of them") {
  // Putamen L (n = 12): without them the mesh rests on the g crossings and
  // converges there; with k of them the run is the same up to that rest, then
  // at most k steps more, and the boundaries move outwards. Since the step
  // guard stops only the patch that keeps crossing (issue 29) the first
  // partial-volume step already brings it to rest: 14 -> 15 steps at every k
  // (before, k = 1 and 2 took exactly k and k = 4 three).
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  StructureRunOptions ro;
  ro.partial_volume_steps = 0;
  const StructureResult off = segment_structure(t1, aal, 73, "putamen L", 12, 100, ro);
  for (int k : {1, 2, 4}) {
    CAPTURE(k);
    ro.partial_volume_steps = k;
    ro.check_mesh = k == 4;
    const StructureResult r = segment_structure(t1, aal, 73, "putamen L", 12, 100, ro);
    MESSAGE("steps " << off.steps << " -> " << r.steps << ", " << off.m.vol_a_ml << " -> " << r.m.vol_a_ml << " ml");
    CHECK(r.steps > off.steps);
    CHECK(r.steps <= off.steps + k);
    CHECK(r.m.vol_a_ml > off.m.vol_a_ml);
    CHECK(r.intersections == 0);
    CHECK(r.flips == 0);
  }
}

namespace {


}  // namespace

TEST_CASE("chapter 6 on Colin27: the eight deep nuclei together never overlap and keep their Dice alone") {
  // Caudate, putamen, pallidum, thalamus L/R (AAL 71-78), protocol spheres,
  // n = 12, defaults, one engine. Measured (BENCHMARKS section 6): mean Dice
  // 0.462 alone, 0.491 together (+0.029; right +0.051, left +0.007), 0 voxels
  // shared (18,870 alone), no crossing between two meshes after any step.
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  const int labels[8] = {71, 72, 73, 74, 75, 76, 77, 78};
  double alone = 0;
  for (int label : labels) alone += segment_structure(t1, aal, label, "", 12, 100).m.dice / 8;
  ffseg_test::EngineBox eb(8, 12);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume v = volume_of(t1);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const size_t N = aal.data.size();
  for (uint32_t o = 0; o < 8; ++o) {
    std::vector<uint8_t> truth(N);
    for (size_t i = 0; i < N; ++i) truth[i] = aal.data[i] == labels[o];
    std::array<int, 3> ijk{};
    double depth = 0;
    REQUIRE(ffseg_tools::find_deepest_voxel(truth.data(), aal.dims, aal.spacing, &ijk, &depth));
    double c[3];
    for (int r = 0; r < 3; ++r)
      c[r] = t1.index_to_world[4 * r] * ijk[0] + t1.index_to_world[4 * r + 1] * ijk[1] +
             t1.index_to_world[4 * r + 2] * ijk[2] + t1.index_to_world[4 * r + 3];
    REQUIRE(ffseg_init_sphere(eb.e, o, c, depth / 2) == FFSEG_OK);
  }
  ffseg_status st = FFSEG_OK;
  int steps = 0;
  size_t crossings = 0;
  std::vector<std::vector<float>> xyz(8);
  std::vector<std::vector<uint32_t>> tris(8);
  ffseg_step_info info;
  info.struct_size = sizeof info;
  while (st == FFSEG_OK && steps < 100) {
    st = ffseg_step(eb.e, &info);
    ++steps;
    for (uint32_t o = 0; o < 8; ++o) REQUIRE(ffseg_test::extract(eb.e, o, &xyz[o], &tris[o]));
    for (uint32_t a = 0; a < 8; ++a)
      for (uint32_t b = a + 1; b < 8; ++b) crossings += ffseg_test::crossings_between(xyz[a], tris[a], xyz[b], tris[b]);
  }
  CHECK(st == FFSEG_CONVERGED);  // no nucleus stalls (a border vertex held by a neighbour is no stall)
  CHECK(crossings == 0);  // summed over every step and pair
  std::vector<uint8_t> claimed(N, 0), mask(N);
  size_t shared = 0;
  double together = 0;
  for (uint32_t o = 0; o < 8; ++o) {
    REQUIRE(ffseg_rasterize(eb.e, o, mask.data(), nullptr) == FFSEG_OK);
    std::vector<uint8_t> truth(N);
    for (size_t i = 0; i < N; ++i) {
      truth[i] = aal.data[i] == labels[o];
      shared += mask[i] && claimed[i];
      claimed[i] |= mask[i];
    }
    together += ffseg_tools::compare_masks(mask.data(), truth.data(), aal.dims, aal.spacing).dice / 8;
  }
  MESSAGE("mean Dice alone ", alone, ", together ", together, " after ", steps, " steps");
  CHECK(shared == 0);
  // Issue 16 measured 0.462 alone, 0.491 together. Since the model's
  // statistics come from the search range around the seed's centre (issue 19)
  // the nuclei alone reach 0.475 and together 0.485, and with grey-level
  // creep counted as rest (convergence.cpp) 0.479 and 0.482; with the
  // statistics independent of the storage (box_lattice.h) 0.477 and 0.472:
  // the regions no longer gain Dice; what they give is no shared voxel
  // (18,870 alone), at a cost of at most 0.01.
  CHECK(together >= alone - 0.01);
}

TEST_CASE("chapter 5 on Colin27: the result depends little on the seed (0.6x, 1x, 1.5x the radius, 1 mm shifts)") {
  // Issue 19 asks pairwise Dice >= 0.85 between the six seeds of every
  // structure; not reached. Measured (n = 12) since the sphere's samples are
  // trimmed to its main classes (intensity_model.h): mean pairwise Dice
  // 0.871, 0.899, 0.874, 0.738, 0.957, 0.937, 0.901, 0.817 (mean 0.874, worst
  // pair 0.556, thalamus R: the scene fit merges white matter into the
  // object's class from the +y and +z seeds). Before the trim, since the
  // statistics became independent of the storage (box_lattice.h): 0.854, 0.895, 0.873, 0.724,
  // 0.843, 0.857, 0.897, 0.804 (mean 0.843, worst pair 0.556). Before: mean pairwise Dice per
  // structure 0.872, 0.902, 0.868, 0.862, 0.831, 0.851, 0.901, 0.731 (mean
  // 0.852, worst pair 0.472, hippocampus R); with the statistics box alone
  // 0.865, 0.894, 0.846, 0.828, 0.815, 0.830, 0.898, 0.720 (0.837, 0.468);
  // before the statistics box
  // (issue 19) 0.838, 0.908, 0.755, 0.690, 0.837, 0.841, 0.832, 0.848 (mean
  // 0.819, worst pair 0.369, thalamus R). Since the step guard stops only
  // the patch that keeps crossing instead of halving the whole update
  // (issue 29: the fine meshes' jam): 0.875, 0.887, 0.873, 0.697, 0.957,
  // 0.937, 0.901, 0.858 (mean 0.873, worst pair 0.442): the hippocampus R's
  // small seed no longer jams (0.817 -> 0.858), the thalamus R's +y seed,
  // which leaks into the white matter, is no longer held back by the guard
  // (0.738 -> 0.697). The floors guard today's figures.
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  const int labels[] = {73, 74, 77, 78, 71, 72, 37, 38};
  const double scales[6] = {0.6, 1, 1.5, 1, 1, 1};
  const double shifts[6][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  double mean_of_means = 0, worst = 1;
  for (const int label : labels) {
    CAPTURE(label);
    std::vector<std::vector<uint8_t>> masks(6);
    for (int k = 0; k < 6; ++k) {
      StructureRunOptions o;
      o.radius_scale = scales[k];
      o.shift_mm = shifts[k];
      o.mask_out = &masks[k];
      o.check_mesh = k == 2;  // the largest seed's run: no crossing, no flip after any step
      const StructureResult r = segment_structure(t1, aal, label, "", 12, 100, o);
      CHECK(r.intersections == 0);
      CHECK(r.flips == 0);
    }
    double mean = 0;
    for (int a = 0; a < 6; ++a)
      for (int b = a + 1; b < 6; ++b) {
        const double d = dice(masks[a], masks[b]);
        mean += d / 15;
        worst = std::min(worst, d);
      }
    std::printf("seed stability, AAL %d: mean pairwise Dice %.3f\n", label, mean);
    CHECK(mean >= 0.65);
    mean_of_means += mean / 8;
  }
  std::printf("seed stability: mean %.3f, worst pair %.3f\n", mean_of_means, worst);
  CHECK(mean_of_means >= 0.85);
  CHECK(worst >= 0.40);
}

TEST_CASE("chapter 5 on Colin27: the result does not depend on how the volume is stored (flips, permuted axes, type)") {
  // Issue 19: Dice >= 0.995 between the run on ch2 as stored and on the same
  // anatomy stored flipped along each axis, with permuted axes, as f32 and as
  // f64. Before the statistics, the samples and g were made independent of
  // the storage order and type (box_lattice.h, sorted samples, one table for
  // every type), the thalamus R flipped along i scored 0.44 and f32 0.93-1.00.
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  REQUIRE(t1.bytes_per_voxel == 1);
  const int64_t d[3] = {t1.dims[0], t1.dims[1], t1.dims[2]};
  const std::vector<double> raw(t1.data.begin(), t1.data.end());
  const std::vector<StoredVariant> vars = stored_variants(d, t1.index_to_world, raw, FFSEG_U8);
  REQUIRE(vars.size() == 7);
  for (const int label : {73, 78, 71, 38}) {  // the four kinds, both sides
    CAPTURE(label);
    std::vector<uint8_t> truth(aal.data.size());
    for (size_t i = 0; i < truth.size(); ++i) truth[i] = aal.data[i] == label;
    double c[3], r = 0;
    protocol_sphere(t1, truth, c, &r);
    const std::vector<uint8_t> ref = segment_variant(vars[0], c, r, 12);
    REQUIRE(std::count(ref.begin(), ref.end(), 1) > 1000);
    for (size_t v = 1; v < vars.size(); ++v) {
      CAPTURE(vars[v].name);
      const std::vector<uint8_t> m = segment_variant(vars[v], c, r, 12);
      const size_t differ = differing_voxels(ref, m);
      if (differ > 0) std::printf("AAL %d, %s: %zu voxels differ\n", label, vars[v].name.c_str(), differ);
      CHECK(dice(ref, m) >= 0.995);
    }
  }
}
