// Flipping-free deformation (thesis chapter 4) on synthetic binary targets:
// accuracy (Dice of the rasterised mesh), and no flip / no self-intersection
// after every step.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "engine.h"
#include "testing.h"
#include "ffseg.h"
#include "support/deform_run.h"
#include "support/mesh_check.h"
#include "support/phantoms.h"
#include "test_util.h"

using namespace ffseg_test;

namespace {

using RunResult = DeformRunResult;
using RunOptions = DeformRunOptions;

}  // namespace

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
