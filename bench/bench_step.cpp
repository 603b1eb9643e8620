// Whole ffseg_step timings on the thesis' cup (binary target, mesh started
// outside), split by stage, next to the factorisation: the step's cost should
// stay within 1.5x of its own factorisation. Each size runs until the engine
// reports convergence (at most K steps, default 150, the tests' limit); the
// medians are over its steps 2..end (step 1 pays for first-touch page
// faults). The last column is the same ratio over steps 2..12 only, the
// heavy start of the run, which earlier tables reported.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "ffseg.h"
#include "../tests/support/phantoms.h"

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int steps = 150;
  if (argc > 1) steps = std::atoi(argv[1]);
  const ffseg_test::Phantom cup = ffseg_test::cup_phantom();
  const char* stage_names[FFSEG_STAGE_COUNT] = {"search", "flips",    "diffusion", "folds",  "assembly",
                                               "factor", "solve",    "features",  "guard",  "regions"};
  std::printf("ffseg_step on the cup phantom (128^3 u8, sphere r = 60 mm around it), run to convergence (at most %d "
              "steps), medians of steps 2..end, one thread\n"
              "(factor = storing the matrix, factorising it and the forward substitution, one pass; bench_solver: "
              "4-7%% over factor() alone at n = 49; solve = the backward substitution)\n\n", steps);
  std::printf("| n | vertices | step ms |");
  for (int s = 0; s < FFSEG_STAGE_COUNT; ++s)
    if (s != FFSEG_STAGE_FEATURES) std::printf(" %s ms |", stage_names[s]);
  std::printf(" steps | step / factor | step / factor, steps 2..12 |\n|---|---|---|");
  for (int s = 0; s < FFSEG_STAGE_COUNT - 1; ++s) std::printf("---|");  // features: grey levels only
  std::printf("---|---|---|\n");
  for (uint32_t n : {21u, 33u, 49u, 65u}) {
    ffseg_config cfg;
    ffseg_config_init_default(&cfg);
    cfg.mesh_resolution = n;
    size_t bytes = 0;
    if (ffseg_workspace_size(&cfg, &bytes) != FFSEG_OK) return 1;
    void* ws = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
    ffseg_engine* e = nullptr;
    if (ffseg_create(&cfg, ws, bytes, &e) != FFSEG_OK) return 1;
    ffseg_volume v;
    std::memset(&v, 0, sizeof v);
    v.struct_size = sizeof v;
    v.voxel_type = FFSEG_U8;
    v.data = cup.mask.data();
    v.data_bytes = cup.mask.size();
    for (int a = 0; a < 3; ++a) v.dims[a] = cup.dims[a];
    v.strides[0] = 1;
    v.strides[1] = cup.dims[0];
    v.strides[2] = cup.dims[0] * cup.dims[1];
    std::memcpy(v.index_to_world, cup.affine, sizeof v.index_to_world);
    v.rescale_slope = 1;
    if (ffseg_set_volume(e, &v) != FFSEG_OK || ffseg_init_sphere(e, 0, cup.center, 60) != FFSEG_OK) return 1;
    std::vector<double> total, stage[FFSEG_STAGE_COUNT];
    ffseg_step_info info;
    info.struct_size = sizeof info;
    int taken = 0;
    for (int s = 0; s < steps; ++s) {
      const auto t0 = std::chrono::steady_clock::now();
      const ffseg_status st = ffseg_step(e, &info);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (st < 0) {
        std::fprintf(stderr, "step failed: %s\n", ffseg_last_error(e));
        return 1;
      }
      taken = s + 1;
      if (st == FFSEG_CONVERGED) break;
      if (s == 0) continue;  // the first step pays for first-touch page faults
      total.push_back(ms);
      for (int q = 0; q < FFSEG_STAGE_COUNT; ++q) stage[q].push_back(info.stage_us[q] / 1000.0);
    }
    const double f = median(stage[FFSEG_STAGE_FACTOR]);
    std::printf("| %u | %u | %.2f |", n, 6 * n * n, median(total));
    for (int q = 0; q < FFSEG_STAGE_COUNT; ++q)
      if (q != FFSEG_STAGE_FEATURES) std::printf(" %.2f |", median(stage[q]));
    const size_t early = total.size() < 11 ? total.size() : 11;
    const std::vector<double> e_total(total.begin(), total.begin() + long(early)),
        e_factor(stage[FFSEG_STAGE_FACTOR].begin(), stage[FFSEG_STAGE_FACTOR].begin() + long(early));
    const double ef = median(e_factor);
    std::printf(" %d | %.2fx | %.2fx |\n", taken, f > 0 ? median(total) / f : 0.0, ef > 0 ? median(e_total) / ef : 0.0);
    ffseg_destroy(e);
    std::free(ws);
  }
  return 0;
}
