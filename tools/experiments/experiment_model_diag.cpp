// Experiment (not a test): what the chapter 5 intensity model alone accepts,
// independent of the mesh. For each labelled structure, the model is fit as
// the engine fits it (protocol sphere, crop = ball of radius r + 20 mm, the
// statistics over the ball of 20 mm around the centre); then over a larger
// crop: the fraction of label voxels it accepts, and the 6-connected accepted
// region grown from the sphere centre against the label. Colin27 and eight
// AAL structures by default; any volume with FFSEG_VOLUME, FFSEG_LABELS and
// FFSEG_IDS (comma-separated label ids), e.g. the abdominal CT:
//   FFSEG_VOLUME=../shared/data/abdomen_ct/ct.nii.gz \
//   FFSEG_LABELS=../shared/data/abdomen_ct/labels.nii.gz FFSEG_IDS=4,10 \
//   FFSEG_VERBOSE=1 build/experiment_model_diag
// Built with the tests, never run by ctest (was the skipped case in
// tests/test_model_diag.cpp).
//
//   build/experiment_model_diag
//   FFSEG_GAMMA=0.3 FFSEG_SIGF=0.1 FFSEG_VERBOSE=1 build/experiment_model_diag
//
// Environment: FFSEG_GAMMA acceptance level of g (0.2), FFSEG_SIGF
// sigma_floor_fraction (0.04), FFSEG_VERBOSE the label's intensity quantiles
// and the fitted components.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "cli/cli.h"
#include "intensity_model.h"
#include "metrics.h"
#include "nifti.h"
#include "smoothing.h"
#include "test_util.h"
#include "volume.h"

using namespace ffseg;

TEST_CASE("colin27 model diagnostic") {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  const char* vol_path = std::getenv("FFSEG_VOLUME");
  const char* lab_path = std::getenv("FFSEG_LABELS");
  REQUIRE(ffseg_tools::nifti_read_file(vol_path ? vol_path : "/usr/share/mricron/templates/ch2.nii.gz", &t1, &err));
  REQUIRE(ffseg_tools::nifti_read_file(lab_path ? lab_path : "/usr/share/mricron/templates/aal.nii.gz", &aal, &err));
  VolumeDesc d{};
  d.type = uint32_t(t1.voxel_type);
  d.data = t1.data.data();
  d.data_bytes = t1.data.size();
  for (int a = 0; a < 3; ++a) d.dims[a] = t1.dims[a];
  d.strides[0] = t1.bytes_per_voxel;
  d.strides[1] = int64_t(t1.bytes_per_voxel) * t1.dims[0];
  d.strides[2] = int64_t(t1.bytes_per_voxel) * t1.dims[0] * t1.dims[1];
  for (int i = 0; i < 16; ++i) d.index_to_world[i] = t1.index_to_world[i];
  d.slope = 1;
  d.intercept = 0;
  VolumeView vol;
  char msg[256];
  INFO(msg);
  REQUIRE(vol.assign(d, msg, sizeof msg));
  const double gamma = std::getenv("FFSEG_GAMMA") ? std::atof(std::getenv("FFSEG_GAMMA")) : 0.2;
  const double sigf = std::getenv("FFSEG_SIGF") ? std::atof(std::getenv("FFSEG_SIGF")) : 0.04;
  std::vector<int> labels = {73, 74, 77, 78, 71, 72, 37, 38};
  if (const char* ids = std::getenv("FFSEG_IDS")) {
    labels.clear();
    for (const char* q = ids; *q;) {
      labels.push_back(std::atoi(q));
      while (*q && *q != ',') ++q;
      if (*q == ',') ++q;
    }
  }
  std::printf("| AAL | comps | competitors | truth accepted | grown Dice | grown ml / true ml | accepted in 3 mm shell |\n|---|---|---|---|---|---|---|\n");
  for (int label : labels) {
    // Label maps come as any voxel type (the abdominal CT's is float64).
    const size_t N = size_t(aal.voxel_count());
    std::vector<uint8_t> truth(N);
    ffseg_cli::for_each_stored(aal, [&](size_t i, double v) { truth[i] = std::lround(v) == label; });
    std::array<int, 3> ijk{};
    double depth = 0;
    REQUIRE(ffseg_tools::find_deepest_voxel(truth.data(), aal.dims, aal.spacing, &ijk, &depth));
    const double r = depth / 2;
    double cidx[3] = {double(ijk[0]), double(ijk[1]), double(ijk[2])}, c[3];
    vol.index_to_world(cidx, c);
    SmoothedRoi roi, big;
    IntensityModel model;
    ffseg_test::ArenaBox box([&](Arena& a) {
      roi.carve(a, 4000000, ffseg::CpuDispatch::detect());
      big.carve(a, 8000000, ffseg::CpuDispatch::detect());
      model.carve(a, IntensityModel::kDefaultSamples, ffseg::CpuDispatch::detect());
    });
    REQUIRE(box.ok());
    int64_t lo[3], hi[3], blo[3], bhi[3];
    const int64_t m = int64_t(std::ceil(r + 20)), bm = 45;
    for (int a = 0; a < 3; ++a) {
      lo[a] = ijk[a] - m;
      hi[a] = ijk[a] + m + 1;
      blo[a] = ijk[a] - bm;
      bhi[a] = ijk[a] + bm + 1;
    }
    SmoothingSettings sm;
    int64_t slo[3], shi[3];  // the engine's statistics box: the search range around the centre
    roi_box_for_ball(vol, c, 20.0, slo, shi);
    roi_box_for_ball(vol, c, r + 20.0, lo, hi);
    sm.stats_lo = slo;
    sm.stats_hi = shi;
    REQUIRE(roi.compute(vol, lo, hi, sm) == RoiStatus::ok);
    IntensityModelSettings ms;
    ms.sigma_floor_fraction = sigf;
    REQUIRE(model.fit(roi, c, r, ms, nullptr, 0, &vol) == ModelStatus::ok);  // raw: as the engine fits it
    sm.kappa = roi.kappa();
    sm.stats_lo = sm.stats_hi = nullptr;
    REQUIRE(big.compute(vol, blo, bhi, sm) == RoiStatus::ok);
    const int* D = aal.dims;
    auto lin = [&](int64_t i, int64_t j, int64_t k) { return size_t(i + D[0] * (j + int64_t(D[1]) * k)); };
    std::vector<uint8_t> acc(N, 0), grown(N, 0);
    size_t tacc = 0, tn = 0;
    std::vector<float> tv;
    for (int64_t k = std::max<int64_t>(blo[2], 0); k < std::min<int64_t>(bhi[2], D[2]); ++k)
      for (int64_t j = std::max<int64_t>(blo[1], 0); j < std::min<int64_t>(bhi[1], D[1]); ++j)
        for (int64_t i = std::max<int64_t>(blo[0], 0); i < std::min<int64_t>(bhi[0], D[0]); ++i) {
          const size_t q = lin(i, j, k);
          acc[q] = model.g(big.at(i, j, k)) >= gamma;
          if (truth[q]) {
            tv.push_back(big.at(i, j, k));
            ++tn;
            tacc += acc[q];
          }
        }
    std::vector<size_t> stack{lin(ijk[0], ijk[1], ijk[2])};
    grown[stack[0]] = 1;
    while (!stack.empty()) {
      const size_t q = stack.back();
      stack.pop_back();
      const int64_t i = int64_t(q % D[0]), j = int64_t((q / D[0]) % D[1]), k = int64_t(q / (size_t(D[0]) * D[1]));
      const int64_t nb[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
      for (auto& p : nb) {
        if (p[0] < blo[0] + 1 || p[1] < blo[1] + 1 || p[2] < blo[2] + 1 || p[0] >= bhi[0] - 1 || p[1] >= bhi[1] - 1 ||
            p[2] >= bhi[2] - 1)
          continue;
        const size_t u = lin(p[0], p[1], p[2]);
        if (acc[u] && !grown[u]) {
          grown[u] = 1;
          stack.push_back(u);
        }
      }
    }
    const auto gm = ffseg_tools::compare_masks(grown.data(), truth.data(), aal.dims, aal.spacing);
    // Shell: voxels within 3 mm outside the label.
    auto dist = ffseg_tools::edt_mm(truth.data(), aal.dims, aal.spacing);
    size_t sh = 0, sha = 0;
    for (size_t q = 0; q < N; ++q)
      if (!truth[q] && dist[q] <= 3.0 && dist[q] > 0) {
        ++sh;
        sha += acc[q];
      }
    std::printf("| %d | %u | %u | %.2f | %.3f | %.2f / %.2f | %.2f |\n", label, model.components(), model.competitors(),
                double(tacc) / double(tn), gm.dice, gm.vol_a_ml, gm.vol_b_ml, double(sha) / double(sh));
    if (std::getenv("FFSEG_VERBOSE")) {
      std::sort(tv.begin(), tv.end());
      std::printf("   sphere r %.1f mm, sigma_floor %.1f, noise %.1f (decorrelated %.1f), contrast %.1f..%.1f\n", r,
                  model.sigma_floor(), roi.noise_sigma(), roi.decorrelated_noise_sigma(), roi.contrast_low(), roi.contrast_high());
      std::printf("   truth smoothed intensity p5 %.1f p25 %.1f p50 %.1f p75 %.1f p95 %.1f\n", tv[tv.size() / 20],
                  tv[tv.size() / 4], tv[tv.size() / 2], tv[3 * tv.size() / 4], tv[19 * tv.size() / 20]);
      for (uint32_t i = 0; i < model.components(); ++i)
        std::printf("   obj %u: w %.3f mu %.1f sd %.1f\n", i, model.component(i).weight, model.component(i).mean,
                    std::sqrt(model.component(i).var));
      for (uint32_t i = 0; i < model.competitors(); ++i)
        std::printf("   comp %u: w %.3f mu %.1f sd %.1f\n", i, model.competitor(i).weight, model.competitor(i).mean,
                    std::sqrt(model.competitor(i).var));
    }
  }
}
