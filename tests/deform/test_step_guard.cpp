// The step guard (src/deform/step_guard.h) on the bare cube-sphere: a step
// that would cross itself or another object backs off where it crosses; its
// fold-test cache.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "cubesphere.h"
#include "diffusion.h"
#include "mesh_contact.h"
#include "mesh_intersection.h"
#include "step_guard.h"
#include "support/sphere_box.h"
#include "test_util.h"
#include "testing.h"

using StageBox = ffseg_test::TriangleBox;


TEST_CASE("step guard: a step that would cross is held back where it crosses, the rest moves in full") {
  // The guard first scales the whole update by 1, 1/2, 1/4; when even a
  // quarter would cross, only the region around the offender backs off.
  StageBox b(12);
  const uint32_t nv = b.m.nv;
  const std::vector<double> x_old = b.sphere(10);
  // Proposal: every vertex 1 mm outward; one vertex 50 mm through the far side
  // (a quarter of that still crosses).
  const uint32_t bad = nv / 3;
  std::vector<double> x_new(size_t(3) * nv);
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      x_new[size_t(a) * nv + v] = (v == bad ? -50.0 : 11.0) * b.m.unit[3 * v + a];
  std::vector<double> xs(size_t(3) * nv), share(nv);
  std::vector<uint8_t> mark(nv), grow(nv);
  const double kept = ffseg::guard_step(b.m, x_old.data(), x_new.data(), xs.data(), share.data(), mark.data(),
                                        grow.data(), b.tri);
  CAPTURE(kept);
  CHECK(kept < 1.0);
  CHECK(kept > 0.5);  // one region backs off, not the whole mesh
  std::vector<double> out(size_t(3) * nv);
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) out[3 * v + a] = x_new[size_t(a) * nv + v];
  CHECK(ffseg::mark_intersections(b.m, out.data(), b.tri, nullptr) == 0);
  CHECK(ffseg::mark_violations(b.m, x_old.data(), out.data(), nullptr) == 0);
  // A vertex a quarter turn away from the offender (its path and the spot
  // where it would come out are both far) moved its full millimetre.
  uint32_t far = 0;
  double best = 1e300;
  for (uint32_t v = 0; v < nv; ++v) {
    double dot = 0;
    for (int a = 0; a < 3; ++a) dot += b.m.unit[3 * v + a] * b.m.unit[3 * bad + a];
    if (std::fabs(dot) < best) { best = std::fabs(dot); far = v; }
  }
  double r = 0;
  for (int a = 0; a < 3; ++a) r += out[3 * far + a] * out[3 * far + a];
  CAPTURE(far);
  CAPTURE(share[far]);
  CHECK(std::sqrt(r) == doctest::Approx(11.0).epsilon(1e-9));
  // The offender did not go through.
  double dot = 0;
  for (int a = 0; a < 3; ++a) dot += out[3 * bad + a] * b.m.unit[3 * bad + a];
  CHECK(dot > 0);
}

TEST_CASE("step guard: the last step's fold-test cache, swapped in at its accepted positions, changes nothing") {
  // One scratch kept across steps (the cache of the accepted positions is
  // reused as the next step's old one) against a scratch told each time that
  // it has nothing to reuse: the same shares and positions bit for bit, over
  // steps that pass whole, back off locally and back off entirely.
  StageBox a(12), b(12);
  const uint32_t nv = a.m.nv;
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<double> x = a.sphere(10);
  std::vector<double> xs(size_t(3) * nv), share(nv), xs2(size_t(3) * nv), share2(nv);
  std::vector<uint8_t> mark(nv), grow(nv), mark2(nv), grow2(nv);
  uint32_t backed_off = 0;
  for (int step = 0; step < 12; ++step) {
    CAPTURE(step);
    std::vector<double> prop(size_t(3) * nv);
    const uint32_t bad = step % 3 == 1 ? uint32_t(step * 37) % nv : nv;  // every third: one vertex through
    for (uint32_t v = 0; v < nv; ++v)
      for (int c = 0; c < 3; ++c)
        prop[size_t(c) * nv + v] = v == bad ? -5.0 * x[3 * v + c] : x[3 * v + c] + 0.3 * U(rng);
    std::vector<double> p1 = prop, p2 = prop;
    b.tri.new_key_valid = false;
    const double k1 = ffseg::guard_step(a.m, x.data(), p1.data(), xs.data(), share.data(), mark.data(), grow.data(),
                                        a.tri);
    const double k2 = ffseg::guard_step(b.m, x.data(), p2.data(), xs2.data(), share2.data(), mark2.data(),
                                        grow2.data(), b.tri);
    CHECK(k1 == k2);
    CHECK(share == share2);
    REQUIRE(p1 == p2);
    backed_off += k1 < 1.0;
    for (uint32_t v = 0; v < nv; ++v)
      for (int c = 0; c < 3; ++c) x[3 * v + c] = p1[size_t(c) * nv + v];
    CHECK(ffseg::mark_intersections(a.m, x.data(), a.tri, nullptr) == 0);
  }
  CHECK(backed_off >= 3);
  CHECK(ffseg::TriangleScratchTesting::reused_old_cache(a.tri) >= 6);  // swapped in on most steps
  CHECK(ffseg::TriangleScratchTesting::reused_old_cache(b.tri) == 0);
}

namespace {

// Columns (x_new[c * nv + v]) back to 3 per vertex.
std::vector<double> rows(const std::vector<double>& cols, uint32_t nv) {
  std::vector<double> out(size_t(3) * nv);
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) out[3 * size_t(v) + a] = cols[size_t(a) * nv + v];
  return out;
}

}  // namespace

TEST_CASE("step guard: a step that would push one object into another is held back only where they touch") {
  // Sphere A (r 10) grows 4 mm; sphere B lies 0.5 mm off A's +x side, so
  // even a quarter of the step would cross it there. The guard with B as an
  // obstacle holds back the side facing B; the far side grows its full 4 mm.
  for (uint32_t n : {12u, 21u}) {
    CAPTURE(n);
    ffseg_test::ContactBox b(n, 1);
    const uint32_t nv = b.m.nv;
    const std::vector<double> x_old = b.sphere(10);
    const std::vector<double> B = b.sphere(10, 20.5, 0.23, -0.17);
    std::vector<double> prop(size_t(3) * nv);
    for (uint32_t v = 0; v < nv; ++v)
      for (int a = 0; a < 3; ++a) prop[size_t(a) * nv + v] = 14.0 * b.m.unit[3 * v + a];
    // The obstacles as the engine builds them: only B's faces within the
    // step's region enter the grid.
    const double* obst[1] = {B.data()};
    double region[6];
    ffseg::guard_region(b.m, x_old.data(), prop.data(), region);
    bool holds = true;  // both ends of every vertex's path, and tight
    double widest = 0;
    for (uint32_t v = 0; v < nv; ++v)
      for (int a = 0; a < 3; ++a) {
        const double o = x_old[3 * size_t(v) + a], p = prop[size_t(a) * nv + v];
        holds = holds && region[a] <= std::fmin(o, p) && std::fmax(o, p) <= region[3 + a];
        widest = std::fmax(widest, std::fabs(p));
      }
    CHECK(holds);
    CHECK(region[3] == widest);
    ffseg::build_obstacles(b.m, obst, 1, b.cs, region);
    REQUIRE(ffseg::mark_contacts(b.m, x_old.data(), b.cs, nullptr) == 0);
    std::vector<double> xs(size_t(3) * nv), share(nv);
    std::vector<uint8_t> mark(nv), grow(nv);
    // Without the obstacle the whole step passes, into B.
    std::vector<double> alone = prop;
    CHECK(ffseg::guard_step(b.m, x_old.data(), alone.data(), xs.data(), share.data(), mark.data(), grow.data(),
                            b.tri) == 1.0);
    CHECK(ffseg::mark_contacts(b.m, rows(alone, nv).data(), b.cs, nullptr) > 0);
    std::vector<double> x_new = prop;
    const double kept = ffseg::guard_step(b.m, x_old.data(), x_new.data(), xs.data(), share.data(), mark.data(),
                                          grow.data(), b.tri, &b.cs);
    CAPTURE(kept);
    CHECK(kept < 1.0);
    CHECK(kept > 0.75);  // one side backs off, not the whole mesh
    const std::vector<double> out = rows(x_new, nv);
    CHECK(ffseg::mark_contacts(b.m, out.data(), b.cs, nullptr) == 0);
    CHECK(ffseg::mark_intersections(b.m, out.data(), b.tri, nullptr) == 0);
    CHECK(ffseg::mark_violations(b.m, x_old.data(), out.data(), nullptr) == 0);
    uint32_t far = 0, facing = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      const double* p = &out[3 * size_t(v)];
      const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      const double ux = b.m.unit[3 * size_t(v)];
      if (ux < 0) {  // the far half moved in full
        ++far;
        CHECK(r == doctest::Approx(14.0).epsilon(1e-12));
      }
      if (ux > 0.99) {  // facing B: stayed short of it
        ++facing;
        CHECK(p[0] < 10.5);
      }
    }
    CHECK(far > nv / 3);
    CHECK(facing > 0);
  }
}

TEST_CASE("step guard: no obstacles or an empty obstacle set change nothing, bit for bit") {
  // The crossing and fold test of the first case, guarded three ways.
  ffseg_test::ContactBox b(12, 2);
  const uint32_t nv = b.m.nv;
  const std::vector<double> x_old = b.sphere(10);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<double> prop(size_t(3) * nv);
  const uint32_t bad = nv / 3;
  for (uint32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      prop[size_t(a) * nv + v] = (v == bad ? -50.0 : 11.0) * b.m.unit[3 * v + a] + 0.2 * U(rng);
  const std::vector<double> far = b.sphere(3, 60, 0, 0);
  const double* obst[1] = {far.data()};
  std::vector<double> results[3];
  std::vector<double> shares[3];
  for (int k = 0; k < 3; ++k) {
    std::vector<double> x_new = prop, xs(size_t(3) * nv), share(nv);
    std::vector<uint8_t> mark(nv), grow(nv);
    b.tri.new_key_valid = false;
    ffseg::build_obstacles(b.m, obst, k == 1 ? 0 : 1, b.cs);
    ffseg::guard_step(b.m, x_old.data(), x_new.data(), xs.data(), share.data(), mark.data(), grow.data(), b.tri,
                      k == 0 ? nullptr : &b.cs);
    results[k] = x_new;
    shares[k] = share;
  }
  CHECK(results[0] != prop);  // the guard did back off
  CHECK(results[1] == results[0]);
  CHECK(results[2] == results[0]);
  CHECK(shares[1] == shares[0]);
  CHECK(shares[2] == shares[0]);
}

TEST_CASE("step guard: two objects stepped in turn towards each other never end a step in contact") {
  // A and B (n = 12, rough spheres 4 mm apart) each propose to move 1.5 mm
  // towards the other per step, with noise; each is guarded against the
  // other's current mesh, in turn. After every step: no contact either way,
  // no self-intersection; and they do close the gap (the guard holds back
  // the contact, not the whole motion).
  ffseg_test::ContactBox a(12, 1), b(12, 1);
  const uint32_t nv = a.m.nv;
  std::mt19937_64 rng(1616);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<double> X[2] = {a.sphere(10), a.sphere(10, 24.0, 0.4, -0.3)};
  const double dir[2] = {1.0, -1.0};
  ffseg_test::ContactBox* box[2] = {&a, &b};
  std::vector<double> xs(size_t(3) * nv), share(nv);
  std::vector<uint8_t> mark(nv), grow(nv);
  uint32_t held = 0;
  for (int step = 0; step < 16; ++step) {
    for (int i = 0; i < 2; ++i) {
      CAPTURE(step);
      CAPTURE(i);
      ffseg_test::ContactBox& g = *box[i];
      const std::vector<double>& other = X[1 - i];
      std::vector<double> prop(size_t(3) * nv);
      for (uint32_t v = 0; v < nv; ++v)
        for (int c = 0; c < 3; ++c)
          prop[size_t(c) * nv + v] = X[i][3 * size_t(v) + c] + (c == 0 ? 1.5 * dir[i] : 0.0) + 0.15 * U(rng);
      const double* obst[1] = {other.data()};
      double region[6];
      ffseg::guard_region(g.m, X[i].data(), prop.data(), region);
      ffseg::build_obstacles(g.m, obst, 1, g.cs, region);
      const double kept = ffseg::guard_step(g.m, X[i].data(), prop.data(), xs.data(), share.data(), mark.data(),
                                            grow.data(), g.tri, &g.cs);
      held += kept < 1.0;
      X[i] = rows(prop, nv);
      ffseg::build_obstacles(g.m, obst, 1, g.cs);
      REQUIRE(ffseg::mark_contacts(g.m, X[i].data(), g.cs, nullptr) == 0);
      const double* mine[1] = {X[i].data()};
      ffseg::build_obstacles(g.m, mine, 1, g.cs);
      REQUIRE(ffseg::mark_contacts(g.m, other.data(), g.cs, nullptr) == 0);
      REQUIRE(ffseg::mark_intersections(g.m, X[i].data(), g.tri, nullptr) == 0);
    }
  }
  CAPTURE(held);
  CHECK(held > 4);
  // The meshes met: their closest vertices are under a millimetre apart
  // (they started 4 mm apart).
  double closest = 1e300, reach = -1e300;
  for (uint32_t v = 0; v < nv; ++v) {
    reach = std::fmax(reach, X[0][3 * size_t(v)]);
    for (uint32_t w = 0; w < nv; ++w) {
      double d2 = 0;
      for (int c = 0; c < 3; ++c) {
        const double d = X[0][3 * size_t(v) + c] - X[1][3 * size_t(w) + c];
        d2 += d * d;
      }
      closest = std::fmin(closest, d2);
    }
  }
  CAPTURE(reach);
  CHECK(std::sqrt(closest) < 1.0);
  CHECK(reach > 12.0);  // from 10: A advanced, as B came to meet it
}
