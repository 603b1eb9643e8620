// Experiment (not a test): how much a Colin27 result depends on its seed
// (issue 19). For each AAL structure of the protocol, the protocol sphere at
// 0.6x, 1x and 1.5x its radius and moved by 1 mm along each axis: Dice of
// each against AAL and the pairwise Dice between the six results.
//
//   FFSEG_N=12 [FFSEG_ONLY=73,74] build/experiment_stability
// (parameters from the environment as in experiment_colin27: tune_from_env)
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "support/colin27_run.h"
#include "tune_from_env.h"
#include "support/phantoms.h"

#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

using namespace ffseg_test;

TEST_CASE("stability experiment") {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  const std::pair<int, const char*> structures[] = {{73, "putamen L"}, {74, "putamen R"}, {77, "thalamus L"},
                                                    {78, "thalamus R"}, {71, "caudate L"}, {72, "caudate R"},
                                                    {37, "hippocampus L"}, {38, "hippocampus R"}};
  const uint32_t n = std::getenv("FFSEG_N") ? uint32_t(std::atoi(std::getenv("FFSEG_N"))) : 12;
  const char* only = std::getenv("FFSEG_ONLY");
  std::printf("| structure | Dice (volume, steps) x0.6 / x1 / x1.5 / +x / +y / +z | pairwise Dice min / mean |\n|---|---|---|\n");
  double all_min = 1, all_mean = 0;
  int count = 0;
  for (auto& st : structures) {
    if (only && std::string(only).find(std::to_string(st.first)) == std::string::npos) continue;
    const double scales[6] = {0.6, 1, 1.5, 1, 1, 1};
    const double shifts[6][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    std::vector<std::vector<uint8_t>> masks(6);
    std::string dices;
    for (int k = 0; k < 6; ++k) {
      StructureRunOptions o;
      o.radius_scale = scales[k];
      o.shift_mm = shifts[k];
      o.mask_out = &masks[k];
      o.tune = ffseg_experiments::tune_from_env;
      const StructureResult r = segment_structure(t1, aal, st.first, st.second, n, 100, o);
      char b[64];
      std::snprintf(b, sizeof b, "%s%.3f (%.1f ml, %d steps)", k ? " / " : "", r.m.dice, r.m.vol_a_ml, r.steps);
      dices += b;
    }
    double mn = 1, mean = 0;
    int pairs = 0;
    for (int a = 0; a < 6; ++a)
      for (int b = a + 1; b < 6; ++b) {
        const double d = dice(masks[a], masks[b]);
        mn = d < mn ? d : mn;
        mean += d;
        ++pairs;
      }
    mean /= pairs;
    std::printf("| %s | %s | %.3f / %.3f |\n", st.second, dices.c_str(), mn, mean);
    all_min = mn < all_min ? mn : all_min;
    all_mean += mean;
    ++count;
  }
  std::printf("worst pairwise Dice %.3f, mean of the structures' mean pairwise Dice %.3f\n", all_min, all_mean / count);
}
