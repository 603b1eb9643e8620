// Flipping-free deformation (thesis chapter 4) on synthetic binary targets:
// accuracy (Dice of the rasterised mesh), and no flip / no self-intersection
// after every step.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "../capi/capi_internal.h"  // engine_of(): the naive-variant test hook
#include "engine.h"
#include "testing.h"
#include "ffseg.h"
#include "support/mesh_check.h"
#include "support/phantoms.h"
#include "test_util.h"

using namespace ffseg_test;

namespace {

struct RunResult {
  double dice = 0;
  int steps = 0;
  bool converged = false;
  size_t intersections = 0;  // worst over all steps
  size_t flips = 0;          // worst over all steps
  bool closed = true;
  ffseg_status last = FFSEG_OK;
};

struct RunOptions {
  uint32_t n = 21;
  double alpha = 0.5;
  double center[3] = {0, 0, 0};
  double radius = 10;
  int max_steps = 150;
  bool check_every_step = true;
  bool naive = false;
  bool verbose = false;
  double search_range = 0;  // 0: the default
  double convergence = 0;   // 0: the default
};

RunResult run_deform(const Phantom& ph, const RunOptions& o) {
  RunResult res;
  EngineBox eb(1, o.n);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.step_size = o.alpha;
  if (o.search_range > 0) p.search_range_mm = o.search_range;
  if (o.convergence > 0) p.convergence_mm = o.convergence;
  if (const char* e = std::getenv("FFSEG_LL")) p.lambda_laplacian = std::atof(e);
  if (const char* e = std::getenv("FFSEG_LP")) p.lambda_position = std::atof(e);
  if (const char* e = std::getenv("FFSEG_LU")) p.lambda_uniform = std::atof(e);
  if (const char* e = std::getenv("FFSEG_DIFF")) p.diffusion_iterations = uint32_t(std::atoi(e));
  if (const char* e = std::getenv("FFSEG_TAU")) p.flip_tau = std::atof(e);
  if (const char* e = std::getenv("FFSEG_CONV")) p.convergence_mm = std::atof(e);
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume v = make_volume(ph.mask.data(), FFSEG_U8, ph.dims, ph.affine);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, o.center, o.radius) == FFSEG_OK);
  if (o.naive) ffseg::EngineTesting::set_naive(*ffseg::capi::engine_of(eb.e), true);
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  ffseg_step_info info;
  info.struct_size = sizeof info;
  for (int s = 0; s < o.max_steps; ++s) {
    res.last = ffseg_step(eb.e, &info);
    REQUIRE(res.last >= 0);
    res.steps = s + 1;
    if (o.check_every_step || res.last == FFSEG_CONVERGED || s + 1 == o.max_steps) {
      REQUIRE(extract(eb.e, 0, &xyz, &tris));
      const SelfIntersectionReport rep = check_self_intersections(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3);
      const size_t bad = rep.disjoint_pairs + rep.shared_vertex_pairs;
      const size_t flips = count_normal_flips(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3, -0.5);
      if (bad > res.intersections) res.intersections = bad;
      if (o.verbose) std::printf("  [step %d: %zu intersecting pairs, %zu normal flips]\n", s + 1, bad, flips);
      if (flips > res.flips) res.flips = flips;
      res.closed = res.closed && is_closed_oriented_manifold(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3);
    }
    if (o.verbose)
      std::printf("  step %3d disp %.4f targets %u flips %u folds %u | search %llu flips %llu diff %llu inter %llu asm %llu fact %llu solve %llu us\n",
                  s + 1, info.mean_displacement_mm[0], info.vertices_with_target[0], info.flips_avoided[0],
                  info.intersections_avoided[0], (unsigned long long)info.stage_us[0], (unsigned long long)info.stage_us[1],
                  (unsigned long long)info.stage_us[2], (unsigned long long)info.stage_us[3],
                  (unsigned long long)info.stage_us[4], (unsigned long long)info.stage_us[5],
                  (unsigned long long)info.stage_us[6]);
    if (std::getenv("FFSEG_STEP_DICE")) {
      std::vector<uint8_t> m(ph.mask.size());
      REQUIRE(ffseg_rasterize(eb.e, 0, m.data(), nullptr) == FFSEG_OK);
      std::printf("  step %d dice %.4f disp %.4f\n", s + 1, dice(m, ph.mask), info.mean_displacement_mm[0]);
    }
    if (const char* dump = std::getenv("FFSEG_DUMP_STEP")) {
      if (std::atoi(dump) == s + 1) {
        REQUIRE(extract(eb.e, 0, &xyz, &tris));
        FILE* f = std::fopen("/tmp/viz/mesh.txt", "w");
        std::fprintf(f, "%zu %zu\n", xyz.size() / 3, tris.size() / 3);
        for (size_t i = 0; i < xyz.size() / 3; ++i) std::fprintf(f, "%g %g %g\n", xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
        for (size_t i = 0; i < tris.size() / 3; ++i) std::fprintf(f, "%u %u %u\n", tris[3 * i], tris[3 * i + 1], tris[3 * i + 2]);
        std::fclose(f);
        f = std::fopen("/tmp/viz/mask.raw", "wb");
        std::fwrite(ph.mask.data(), 1, ph.mask.size(), f);
        std::fclose(f);
      }
    }
    if (res.last == FFSEG_CONVERGED) {
      res.converged = true;
      break;
    }
  }
  std::vector<uint8_t> mask(ph.mask.size());
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  res.dice = dice(mask, ph.mask);
  return res;
}

}  // namespace

TEST_CASE("deform experiment" * doctest::skip()) {
  const char* shape = std::getenv("FFSEG_SHAPE");
  const std::string sh = shape ? shape : "cup";
  Phantom ph;
  RunOptions o;
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
  RunResult r = run_deform(ph, o);
  std::printf("%s n=%u alpha=%.1f dice %.4f steps %d conv %d inter %zu flips %zu closed %d\n", sh.c_str(), o.n, o.alpha,
              r.dice, r.steps, r.converged, r.intersections, r.flips, r.closed);
}

TEST_CASE("naive variant of fig. 4.10 (vertices straight to their targets) self-intersects on the cup") {
  // The guard against the checks failing silently: without flip handling the
  // cup's lid folds through itself within a few steps.
  const Phantom cup = cup_phantom();
  RunOptions o;
  o.n = 33;
  o.alpha = 0.7;
  for (int a = 0; a < 3; ++a) o.center[a] = cup.center[a];
  o.radius = 60;
  o.max_steps = 8;
  o.naive = true;
  const RunResult r = run_deform(cup, o);
  CHECK(r.intersections + r.flips > 0);
}

namespace {

struct Shape {
  const char* name;
  Phantom phantom;
  double radius;
  double dice_floor;       // n = 21
  double dice_floor_fine;  // n = 33 and 49
};

std::vector<Shape> shapes() {
  std::vector<Shape> out;
  const double c[3] = {32, 33, 31};
  out.push_back({"sphere target larger than the mesh", ball_phantom(64, c, 24), 10, 0.98, 0.98});
  out.push_back({"sphere target smaller than the mesh", ball_phantom(64, c, 12), 26, 0.98, 0.98});
  out.push_back({"ellipsoid on a rotated 0.7 x 0.9 x 2.5 mm grid", ellipsoid_phantom(), 8, 0.98, 0.98});
  // The issue asks 0.97 for the cup; measured today (alpha 0.3 / 0.7): 0.972 /
  // 0.977 at n = 21, 0.989 / 0.995 at n = 33, 0.994 / 0.998 at n = 49 (before
  // even diffusion rounds, the tension-only uniform term and the polishing
  // rest test: 0.963 / 0.973 at n = 21, the cavity's bottom corners cut off).
  out.push_back({"the thesis' cup, mesh started outside", cup_phantom(), 60, 0.97, 0.97});
  return out;
}

}  // namespace

TEST_CASE("chapter 4 deformation: Dice floors within 150 steps, no flip and no self-intersection after any step") {
  const std::vector<Shape> all = shapes();
  std::printf("| shape | n | alpha | Dice | steps | converged | worst intersecting pairs | worst normal flips |\n|---|---|---|---|---|---|---|---|\n");
  for (const Shape& sh : all)
    for (uint32_t n : {21u, 33u, 49u})
      for (double alpha : {0.3, 0.7}) {
        CAPTURE(sh.name);
        CAPTURE(n);
        CAPTURE(alpha);
        RunOptions o;
        o.n = n;
        o.alpha = alpha;
        for (int a = 0; a < 3; ++a) o.center[a] = sh.phantom.center[a];
        o.radius = sh.radius;
        o.max_steps = 150;
        const RunResult r = run_deform(sh.phantom, o);
        std::printf("| %s | %u | %.1f | %.4f | %d | %s | %zu | %zu |\n", sh.name, n, alpha, r.dice, r.steps,
                    r.converged ? "yes" : "no", r.intersections, r.flips);
        CHECK(r.dice >= (n >= 33 ? sh.dice_floor_fine : sh.dice_floor));
        CHECK(r.intersections == 0);
        CHECK(r.flips == 0);
        CHECK(r.closed);
      }
}

TEST_CASE("a converged object stays where it is on later steps, until new parameters release it") {
  const double c[3] = {32, 33, 31};
  const Phantom ph = ball_phantom(64, c, 24);
  EngineBox eb(1, 21);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume v = make_volume(ph.mask.data(), FFSEG_U8, ph.dims, ph.affine);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, ph.center, 10) == FFSEG_OK);
  ffseg_step_info info;
  info.struct_size = sizeof info;
  int steps = 0;
  ffseg_status st = FFSEG_OK;
  while (st != FFSEG_CONVERGED && steps < 150) {
    st = ffseg_step(eb.e, &info);
    REQUIRE(st >= 0);
    ++steps;
  }
  REQUIRE(st == FFSEG_CONVERGED);
  std::vector<float> at_rest, later;
  std::vector<uint32_t> tris;
  REQUIRE(extract(eb.e, 0, &at_rest, &tris));
  // Kept stepping, the mesh used to roughen (Dice 0.999 -> 0.983 over 140
  // steps); now every later step reports convergence and moves nothing.
  for (int s = 0; s < 20; ++s) {
    CHECK(ffseg_step(eb.e, &info) == FFSEG_CONVERGED);
    CHECK(info.mean_displacement_mm[0] == 0.0);
  }
  REQUIRE(extract(eb.e, 0, &later, &tris));
  CHECK(later == at_rest);
  // New parameters release it: a much stiffer mesh moves again.
  p.lambda_laplacian = 50;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  REQUIRE(ffseg_step(eb.e, &info) >= 0);
  CHECK(info.mean_displacement_mm[0] > 0.0);
  REQUIRE(extract(eb.e, 0, &later, &tris));
  CHECK(later != at_rest);
  // So does a new volume (a smaller ball): the mesh shrinks onto it.
  p.lambda_laplacian = 1;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  for (int s = 0; s < 150 && ffseg_step(eb.e, &info) != FFSEG_CONVERGED; ++s) {
  }
  const Phantom small = ball_phantom(64, c, 14);
  ffseg_volume v2 = make_volume(small.mask.data(), FFSEG_U8, small.dims, small.affine);
  REQUIRE(ffseg_set_volume(eb.e, &v2) == FFSEG_OK);
  REQUIRE(ffseg_step(eb.e, &info) == FFSEG_OK);
  CHECK(info.mean_displacement_mm[0] > 0.5);
  // And placing the object again starts it over.
  for (int s = 0; s < 150 && ffseg_step(eb.e, &info) != FFSEG_CONVERGED; ++s) {
  }
  REQUIRE(ffseg_step(eb.e, &info) == FFSEG_CONVERGED);
  REQUIRE(ffseg_init_sphere(eb.e, 0, small.center, 5) == FFSEG_OK);
  REQUIRE(ffseg_step(eb.e, &info) == FFSEG_OK);
  CHECK(info.mean_displacement_mm[0] > 0.5);
}

TEST_CASE("stepping on at rest does not roughen the mesh (150 steps, convergence never reached)") {
  // convergence_mm = 0.001 mm is never reached, so the engine keeps stepping
  // at rest. With an odd number of diffusion rounds (the checkerboard mode
  // reversed) or the uniform term pushing short edges apart (a loop buckling)
  // the meshes grew sawtooth spikes: Dice 0.983 (sphere), 0.991 (ellipsoid),
  // 0.956 (cup) after 150 steps.
  const double c[3] = {32, 33, 31};
  struct Case {
    const char* name;
    Phantom ph;
    double radius, floor;
  };
  const Case cases[] = {{"sphere", ball_phantom(64, c, 24), 10, 0.995},
                        {"ellipsoid", ellipsoid_phantom(), 8, 0.995},
                        {"cup", cup_phantom(), 60, 0.97}};
  for (const Case& k : cases) {
    CAPTURE(k.name);
    RunOptions o;
    o.n = 21;
    o.alpha = 0.5;
    for (int a = 0; a < 3; ++a) o.center[a] = k.ph.center[a];
    o.radius = k.radius;
    o.max_steps = 150;
    o.check_every_step = false;
    o.convergence = 0.001;
    const RunResult r = run_deform(k.ph, o);
    std::printf("kept stepping at rest, %s: Dice %.4f after %d steps\n", k.name, r.dice, r.steps);
    CHECK(r.dice >= k.floor);
    CHECK(r.intersections == 0);
    CHECK(r.flips == 0);
  }
}
