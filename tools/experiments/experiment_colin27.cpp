// Experiment (not a test): the eight AAL structures of Colin27 segmented
// from the protocol sphere, a Markdown table on stdout (Dice, VOE, ASSD, HD95,
// steps, ms, volumes); the parameters from the environment. Built with the
// tests, never run by ctest (was the skipped "colin27 experiment" case in
// tests/test_colin27.cpp).
//
//   build/experiment_colin27
//   FFSEG_ONLY=73,74 FFSEG_N=12 FFSEG_STEPS=1 build/experiment_colin27
//
// Environment:
//   FFSEG_ONLY     AAL labels to run (a substring match on the list, e.g. 73,77)
//   FFSEG_N        mesh resolution (33)
//   FFSEG_JITTER   the mean over six perturbed spheres (radius x 0.8, 1, 1.2; centre +1 mm)
//   FFSEG_VERBOSE  the sphere of every structure        FFSEG_STEPS  every step's motion and stage times
//   parameters:    FFSEG_SIGF sigma_floor_fraction, FFSEG_GAMMA intensity_gamma, FFSEG_SR search_range_mm,
//                  FFSEG_ALPHA step_size, FFSEG_SMI smoothing_iterations, FFSEG_NB consecutive_background,
//                  FFSEG_DIFF diffusion_iterations, FFSEG_LL / FFSEG_LU / FFSEG_LP lambda_laplacian /
//                  _uniform / _position, FFSEG_TAU flip_tau, FFSEG_CONV convergence_mm,
//                  FFSEG_PVS partial_volume_steps
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>

#include "support/colin27_run.h"
#include "tune_from_env.h"

using namespace ffseg_test;

namespace {

StructureRunOptions from_env() {
  StructureRunOptions o;
  o.verbose = std::getenv("FFSEG_VERBOSE") != nullptr;
  o.print_steps = std::getenv("FFSEG_STEPS") != nullptr;
  // One seed of the stability experiment: FFSEG_RS radius scale, FFSEG_SHIFT "x,y,z" mm.
  if (const char* e = std::getenv("FFSEG_RS")) o.radius_scale = std::atof(e);
  static double shift[3];
  if (const char* e = std::getenv("FFSEG_SHIFT")) {
    if (std::sscanf(e, "%lf,%lf,%lf", &shift[0], &shift[1], &shift[2]) == 3) o.shift_mm = shift;
  }
  o.tune = ffseg_experiments::tune_from_env;

  return o;
}

}  // namespace

TEST_CASE("colin27 experiment") {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  const std::pair<int, const char*> structures[] = {{73, "putamen L"}, {74, "putamen R"}, {77, "thalamus L"},
                                                    {78, "thalamus R"}, {71, "caudate L"}, {72, "caudate R"},
                                                    {37, "hippocampus L"}, {38, "hippocampus R"}};
  std::printf("| structure | AAL | Dice | VOE | ASSD mm | HD95 mm | steps | ms | ml predicted / true |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  const char* only = std::getenv("FFSEG_ONLY");
  for (auto& st : structures) {
    if (only && std::string(only).find(std::to_string(st.first)) == std::string::npos) continue;
    const uint32_t n = std::getenv("FFSEG_N") ? uint32_t(std::atoi(std::getenv("FFSEG_N"))) : 33;
    StructureResult r = segment_structure(t1, aal, st.first, st.second, n, 100, from_env());
    if (std::getenv("FFSEG_JITTER")) {
      // Mean over six perturbed spheres (radius x 0.8, 1, 1.2; centre as is or
      // shifted by 1 mm along each axis): a steadier figure than one run.
      const double scales[] = {0.8, 1.0, 1.2};
      const double shift[3] = {1, 1, 1};
      StructureResult acc = r;
      acc.m.dice = acc.m.assd_mm = acc.m.vol_a_ml = 0;
      acc.ms = 0;
      acc.steps = 0;
      for (int k = 0; k < 6; ++k) {
        StructureRunOptions ro = from_env();
        ro.radius_scale = scales[k % 3];
        ro.shift_mm = k < 3 ? nullptr : shift;
        const StructureResult q = segment_structure(t1, aal, st.first, st.second, n, 100, ro);
        acc.m.dice += q.m.dice / 6;
        acc.m.assd_mm += q.m.assd_mm / 6;
        acc.m.vol_a_ml += q.m.vol_a_ml / 6;
        acc.ms += q.ms / 6;
        acc.steps += q.steps;
      }
      acc.steps /= 6;
      r = acc;
    }
    std::printf("| %s | %d | %.3f | %.3f | %.2f | %.2f | %d | %.0f | %.2f / %.2f |\n", r.name, r.label, r.m.dice, r.m.voe,
                r.m.assd_mm, r.m.hd95_mm, r.steps, r.ms, r.m.vol_a_ml, r.m.vol_b_ml);
  }
}
