// Experiment (not a test): one chapter 4 run on a binary phantom, its
// parameters from the environment, a one-line summary on stdout. Built with
// the tests, never run by ctest (was the skipped "deform experiment" case in
// tests/test_deform.cpp).
//
//   build/experiment_deform                      # the cup, n = 33, alpha 0.5
//   FFSEG_SHAPE=big FFSEG_N=21 FFSEG_VERBOSE=1 build/experiment_deform
//
// Environment:
//   FFSEG_SHAPE      cup (default) | big (ball larger than the sphere) | small | ellipsoid
//   FFSEG_N          mesh resolution (33)          FFSEG_ALPHA   step size (0.5)
//   FFSEG_SR         search range mm (default)     FFSEG_CONV    convergence mm
//   FFSEG_LL, FFSEG_LP, FFSEG_LU                   lambda_laplacian / _position / _uniform
//   FFSEG_DIFF       diffusion rounds              FFSEG_TAU     flip tau
//   FFSEG_VERBOSE    per-step stage times, intersecting pairs and flips
//   FFSEG_STEP_DICE  Dice after every step
//   FFSEG_DUMP_STEP  K: after step K write /tmp/viz/mesh.txt (vertices, triangles) and /tmp/viz/mask.raw
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "support/deform_run.h"
#include "support/phantoms.h"
#include "test_util.h"

using namespace ffseg_test;

TEST_CASE("deform experiment") {
  const char* shape = std::getenv("FFSEG_SHAPE");
  const std::string sh = shape ? shape : "cup";
  Phantom ph;
  DeformRunOptions o;
  if (sh == "cup") {
    ph = cup_phantom();
    o.radius = 60;
  } else if (sh == "big") {  // target larger than the mesh
    const double c[3] = {32, 33, 31};
    ph = ball_phantom(64, c, 24);
    o.radius = 10;
  } else if (sh == "small") {
    const double c[3] = {32, 33, 31};
    ph = ball_phantom(64, c, 12);
    o.radius = 26;
  } else {
    ph = ellipsoid_phantom();
    o.radius = 8;
  }
  for (int a = 0; a < 3; ++a) o.center[a] = ph.center[a];
  o.n = 33;
  o.alpha = 0.5;
  o.verbose = std::getenv("FFSEG_VERBOSE") != nullptr;
  if (const char* sr = std::getenv("FFSEG_SR")) o.search_range = std::atof(sr);
  if (const char* nn = std::getenv("FFSEG_N")) o.n = uint32_t(std::atoi(nn));
  if (const char* al = std::getenv("FFSEG_ALPHA")) o.alpha = std::atof(al);
  o.max_steps = 150;
  o.tune = [](ffseg_params& p) {
    if (const char* e = std::getenv("FFSEG_LL")) p.lambda_laplacian = std::atof(e);
    if (const char* e = std::getenv("FFSEG_LP")) p.lambda_position = std::atof(e);
    if (const char* e = std::getenv("FFSEG_LU")) p.lambda_uniform = std::atof(e);
    if (const char* e = std::getenv("FFSEG_DIFF")) p.diffusion_iterations = uint32_t(std::atoi(e));
    if (const char* e = std::getenv("FFSEG_TAU")) p.flip_tau = std::atof(e);
    if (const char* e = std::getenv("FFSEG_CONV")) p.convergence_mm = std::atof(e);
  };
  o.after_step = [&ph](int step, ffseg_engine* e, const ffseg_step_info& info) {
    if (std::getenv("FFSEG_STEP_DICE")) {
      std::vector<uint8_t> m(ph.mask.size());
      REQUIRE(ffseg_rasterize(e, 0, m.data(), nullptr) == FFSEG_OK);
      std::printf("  step %d dice %.4f disp %.4f\n", step, dice(m, ph.mask), info.mean_displacement_mm[0]);
    }
    if (const char* dump = std::getenv("FFSEG_DUMP_STEP")) {
      if (std::atoi(dump) == step) {
        std::vector<float> xyz;
        std::vector<uint32_t> tris;
        REQUIRE(extract(e, 0, &xyz, &tris));
        FILE* f = std::fopen("/tmp/viz/mesh.txt", "w");
        REQUIRE(f != nullptr);
        std::fprintf(f, "%zu %zu\n", xyz.size() / 3, tris.size() / 3);
        for (size_t i = 0; i < xyz.size() / 3; ++i) std::fprintf(f, "%g %g %g\n", xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
        for (size_t i = 0; i < tris.size() / 3; ++i) std::fprintf(f, "%u %u %u\n", tris[3 * i], tris[3 * i + 1], tris[3 * i + 2]);
        std::fclose(f);
        f = std::fopen("/tmp/viz/mask.raw", "wb");
        REQUIRE(f != nullptr);
        std::fwrite(ph.mask.data(), 1, ph.mask.size(), f);
        std::fclose(f);
      }
    }
  };
  const DeformRunResult r = run_deform(ph, o);
  std::printf("%s n=%u alpha=%.1f dice %.4f steps %d conv %d inter %zu flips %zu closed %d\n", sh.c_str(), o.n, o.alpha,
              r.dice, r.steps, r.converged, r.intersections, r.flips, r.closed);
}
