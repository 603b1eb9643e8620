// Experiment (not a test): does a Colin27 result depend on how the volume is
// stored (issue 19)? The protocol sphere's structure segmented from ch2 as
// stored (u8), flipped along each axis (affine adjusted: the same anatomy in
// world space), with its axes permuted (i, j, k) -> (j, k, i), and as f32
// and f64 holding the same values (tests/support/stored_variants); each
// mask mapped back to the stored grid, Dice against the stored run and the
// voxels that differ.
//
//   FFSEG_N=12 build/experiment_invariance [FFSEG_ONLY=73,...]
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "metrics.h"
#include "support/colin27_run.h"
#include "support/phantoms.h"
#include "support/stored_variants.h"
#include "test_util.h"

#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

using namespace ffseg_test;

TEST_CASE("invariance experiment") {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  REQUIRE(t1.bytes_per_voxel == 1);
  const size_t N = t1.data.size();
  const int64_t d[3] = {t1.dims[0], t1.dims[1], t1.dims[2]};
  const std::vector<double> raw(t1.data.begin(), t1.data.end());
  const std::vector<StoredVariant> vars = stored_variants(d, t1.index_to_world, raw, FFSEG_U8);
  const std::pair<int, const char*> structures[] = {{73, "putamen L"}, {74, "putamen R"}, {77, "thalamus L"},
                                                    {78, "thalamus R"}, {71, "caudate L"}, {72, "caudate R"},
                                                    {37, "hippocampus L"}, {38, "hippocampus R"}};
  const uint32_t n = std::getenv("FFSEG_N") ? uint32_t(std::atoi(std::getenv("FFSEG_N"))) : 12;
  const char* only = std::getenv("FFSEG_ONLY");
  std::printf("Dice against the run as stored (voxels that differ)\n\n| structure |");
  for (size_t v = 1; v < vars.size(); ++v) std::printf(" %s |", vars[v].name.c_str());
  std::printf("\n|---|");
  for (size_t v = 1; v < vars.size(); ++v) std::printf("---|");
  std::printf("\n");
  for (auto& st : structures) {
    if (only && std::string(only).find(std::to_string(st.first)) == std::string::npos) continue;
    std::vector<uint8_t> truth(N);
    for (size_t i = 0; i < N; ++i) truth[i] = aal.data[i] == st.first;
    double c[3], r = 0;
    protocol_sphere(t1, truth, c, &r);
    const std::vector<uint8_t> ref = segment_variant(vars[0], c, r, n);
    std::printf("| %s |", st.second);
    for (size_t v = 1; v < vars.size(); ++v) {
      const std::vector<uint8_t> m = segment_variant(vars[v], c, r, n);
      std::printf(" %.4f (%zu) |", dice(ref, m), differing_voxels(ref, m));
    }
    std::printf("\n");
  }
}
