// Chapter 5 on a synthetic CT: i16 Hounsfield units with a rescale, spacing
// 0.8 x 0.8 x 2.5 mm, a lobed organ of about 60 HU touching a second organ of
// similar intensity (90 HU) across a weak boundary, fat (-100 HU) around,
// Gaussian noise sigma 15 HU.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "ffseg.h"
#include "support/mesh_check.h"
#include "support/phantoms.h"
#include "support/stored_variants.h"
#include "test_util.h"

namespace {

struct CtPhantom {
  int64_t dims[3] = {160, 140, 48};
  double A[16] = {0.8, 0, 0, -64, 0, 0.8, 0, -56, 0, 0, 2.5, -60, 0, 0, 0, 1};
  std::vector<int16_t> stored;   // (HU + 1024) / 1, rescale intercept -1024
  std::vector<uint8_t> organ;    // truth of the organ
  std::vector<uint8_t> other;    // the touching organ
};

// Lobed organ: a sphere of radius 30 mm modulated by 4 lobes; the neighbour is
// a ball whose surface touches the organ's on the +x side.
bool in_organ(double x, double y, double z) {
  const double r = std::sqrt(x * x + y * y + z * z);
  const double th = std::atan2(y, x);
  const double rz = r > 0 ? z / r : 0;
  const double R = 28.0 * (1.0 + 0.18 * std::cos(4 * th) * (1 - rz * rz));
  return r < R;
}
bool in_other(double x, double y, double z) {
  const double cx = 28.0 * 1.18 + 18.0;  // touches the +x lobe
  return (x - cx) * (x - cx) + y * y + z * z < 18.0 * 18.0;
}

CtPhantom make_ct() {
  CtPhantom p;
  const size_t n = size_t(p.dims[0] * p.dims[1] * p.dims[2]);
  p.stored.resize(n);
  p.organ.resize(n);
  p.other.resize(n);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 15.0);
  for (int64_t k = 0; k < p.dims[2]; ++k)
    for (int64_t j = 0; j < p.dims[1]; ++j)
      for (int64_t i = 0; i < p.dims[0]; ++i) {
        const double x = p.A[0] * i + p.A[3], y = p.A[5] * j + p.A[7], z = p.A[10] * k + p.A[11];
        const size_t q = size_t(i + p.dims[0] * (j + p.dims[1] * k));
        const bool a = in_organ(x, y, z), b = !a && in_other(x, y, z);
        p.organ[q] = a;
        p.other[q] = b;
        const double hu = (a ? 60.0 : b ? 90.0 : -100.0) + noise(rng);
        p.stored[q] = int16_t(std::lround(hu + 1024.0));
      }
  return p;
}

}  // namespace

TEST_CASE("chapter 5 on a synthetic CT: lobed organ next to a touching organ, noise 15 HU") {
  const CtPhantom ct = make_ct();
  ffseg_test::EngineBox eb(1, 33);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume v = ffseg_test::make_volume(ct.stored.data(), FFSEG_I16, ct.dims, ct.A);
  v.rescale_intercept = -1024;
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double c[3] = {0, 0, 0};
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, 10.0) == FFSEG_OK);
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  size_t worst = 0;
  int steps = 0;
  for (; steps < 150; ++steps) {
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    INFO(ffseg_last_error(eb.e));
    REQUIRE(st >= 0);
    REQUIRE(ffseg_test::extract(eb.e, 0, &xyz, &tris));
    const auto rep = ffseg_test::check_self_intersections(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3);
    worst = std::max(worst, rep.disjoint_pairs + rep.shared_vertex_pairs);
    if (st == FFSEG_CONVERGED) { ++steps; break; }
  }
  std::vector<uint8_t> mask(ct.stored.size());
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  size_t both = 0, a = 0, b = 0, leak = 0, other = 0;
  for (size_t q = 0; q < mask.size(); ++q) {
    both += mask[q] && ct.organ[q];
    a += mask[q];
    b += ct.organ[q];
    leak += mask[q] && ct.other[q];
    other += ct.other[q];
  }
  const double dice = 2.0 * double(both) / double(a + b);
  const double leak_frac = double(leak) / double(other);
  std::printf("CT phantom: Dice %.4f, %d steps, %.1f%% of the touching organ taken, worst intersections %zu\n", dice,
              steps, 100 * leak_frac, worst);
  CHECK(dice >= 0.90);
  CHECK(leak_frac < 0.10);
  CHECK(worst == 0);
}

namespace {

// Issue 19's seed-size phantom: a soft organ of 30 HU (an ellipsoid, semi-axes
// 36 x 28 x 24 mm) with two fluid-filled cavities of 5 HU that open on its
// surface (balls of 10 and 8 mm centred on it: the organ's truth excludes
// them, so a mesh that does not stop at the fluid fills them), a bone plate of
// 700 HU touching its -y side, fat of -100 HU everywhere else, Gaussian noise
// sigma 8 HU; i16 with rescale, spacing 0.9 x 0.9 x 1.5 mm. Between bone and
// fat the blurred edge passes through the organ's and the fluid's values: a
// seed-sized trap that must not become a path.
struct CavityPhantom {
  int64_t dims[3] = {120, 110, 60};
  double A[16] = {0.9, 0, 0, -54, 0, 0.9, 0, -49.5, 0, 0, 1.5, -45, 0, 0, 0, 1};
  std::vector<int16_t> stored;
  std::vector<uint8_t> organ, fluid, bone;
};

CavityPhantom make_cavity_phantom() {
  CavityPhantom p;
  const size_t n = size_t(p.dims[0] * p.dims[1] * p.dims[2]);
  p.stored.resize(n);
  p.organ.resize(n);
  p.fluid.resize(n);
  p.bone.resize(n);
  std::mt19937 rng(19);
  std::normal_distribution<double> noise(0.0, 8.0);
  auto ball = [](double x, double y, double z, double cx, double cy, double cz, double r) {
    return (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz) < r * r;
  };
  for (int64_t k = 0; k < p.dims[2]; ++k)
    for (int64_t j = 0; j < p.dims[1]; ++j)
      for (int64_t i = 0; i < p.dims[0]; ++i) {
        const double x = p.A[0] * i + p.A[3], y = p.A[5] * j + p.A[7], z = p.A[10] * k + p.A[11];
        const size_t q = size_t(i + p.dims[0] * (j + p.dims[1] * k));
        const double e = x * x / (36.0 * 36.0) + y * y / (28.0 * 28.0) + z * z / (24.0 * 24.0);
        const bool cav = ball(x, y, z, 36.0, 0, 0, 10.0) || ball(x, y, z, -12.0, 14.0, 20.5, 8.0);
        const bool bone = y < -28.0 && y > -36.0 && std::fabs(x) < 40 && std::fabs(z) < 30;
        const bool organ = e < 1 && !cav;
        p.organ[q] = organ;
        p.fluid[q] = cav && !bone;
        p.bone[q] = bone;
        const double hu = (organ ? 30.0 : p.fluid[q] ? 5.0 : bone ? 700.0 : -100.0) + noise(rng);
        p.stored[q] = int16_t(std::lround(hu + 1024.0));
      }
  return p;
}

}  // namespace

namespace {

// A grey-level run of volume v from the sphere (c, r) at mesh resolution n
// until convergence (at most 150 steps), every step's mesh checked by watch
// when given; the final mask, and the steps taken in *steps.
std::vector<uint8_t> grey_run(const ffseg_volume& v, uint32_t n, const double c[3], double r,
                              ffseg_test::MeshWatch* watch, int* steps) {
  ffseg_test::EngineBox eb(1, n);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  *steps = 0;
  while (*steps < 150) {
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    INFO(ffseg_last_error(eb.e));
    REQUIRE(st >= 0);
    ++*steps;
    if (watch) REQUIRE(watch->look(eb.e, 0));
    if (st == FFSEG_CONVERGED) break;
  }
  const size_t voxels = size_t(v.dims[0] * v.dims[1] * v.dims[2]);
  std::vector<uint8_t> mask(voxels);
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  return mask;
}

}  // namespace

TEST_CASE("chapter 5 on a CT phantom with fluid cavities and bone: seeds of 3, 5 and 10 mm all reach the organ") {
  const CavityPhantom ct = make_cavity_phantom();
  std::vector<std::vector<uint8_t>> masks;
  for (const double r : {3.0, 5.0, 10.0}) {
    CAPTURE(r);
    ffseg_volume v = ffseg_test::make_volume(ct.stored.data(), FFSEG_I16, ct.dims, ct.A);
    v.rescale_intercept = -1024;
    const double c[3] = {-8.0, -4.0, -3.0};  // well inside the organ, off its centre
    ffseg_test::MeshWatch watch;
    int steps = 0;
    const std::vector<uint8_t> mask = grey_run(v, 21, c, r, &watch, &steps);
    size_t in_fluid = 0, fluid = 0, in_bone = 0;
    for (size_t q = 0; q < mask.size(); ++q) {
      in_fluid += mask[q] && ct.fluid[q];
      fluid += ct.fluid[q];
      in_bone += mask[q] && ct.bone[q];
    }
    const double dice = ffseg_test::dice(mask, ct.organ);
    std::printf("cavity phantom, seed %.0f mm: Dice %.4f, %d steps, %.1f%% of the fluid and %zu bone voxels taken\n", r,
                dice, steps, 100.0 * double(in_fluid) / double(fluid), in_bone);
    CHECK(dice >= 0.90);
    CHECK(double(in_fluid) < 0.15 * double(fluid));
    CHECK(in_bone == 0);
    CHECK(watch.intersections == 0);
    CHECK(watch.flips == 0);
    masks.push_back(mask);
  }
  // The three results agree with one another as well as with the truth.
  for (size_t a = 0; a < masks.size(); ++a)
    for (size_t b = a + 1; b < masks.size(); ++b) {
      CAPTURE(a);
      CAPTURE(b);
      CHECK(ffseg_test::dice(masks[a], masks[b]) >= 0.9);
    }
}

TEST_CASE("chapter 5 with non-finite voxels: they never enter the model and read as outside the object") {
  // f32 volume, a ball of 100 in 0, noise sigma 4; a slab of NaN and +inf
  // voxels touching the ball's side, and a cluster of NaN voxels inside the
  // seed sphere itself.
  const int64_t dims[3] = {64, 64, 48};
  const double A[16] = {1, 0, 0, -32, 0, 1, 0, -32, 0, 0, 1, -24, 0, 0, 0, 1};
  const size_t n = size_t(dims[0] * dims[1] * dims[2]);
  std::vector<float> vox(n);
  std::vector<uint8_t> truth(n), bad(n);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 4.0);
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i) {
        const double x = i - 32.0, y = j - 32.0, z = k - 24.0;
        const size_t q = size_t(i + dims[0] * (j + dims[1] * k));
        const bool in = x * x + y * y + z * z < 16.0 * 16.0;
        const bool slab = x > 12 && x < 20 && std::fabs(y) < 6 && std::fabs(z) < 6;
        const bool cluster = std::fabs(x + 1) <= 1 && std::fabs(y) <= 1 && std::fabs(z) <= 1;
        vox[q] = float((in ? 100.0 : 0.0) + noise(rng));
        if (slab) vox[q] = (i + j) % 2 ? NAN : INFINITY;
        if (cluster) vox[q] = NAN;
        bad[q] = slab || cluster;
        truth[q] = in && !bad[q];
      }
  const ffseg_volume v = ffseg_test::make_volume(vox.data(), FFSEG_F32, dims, A);
  const double c[3] = {0, 0, 0};  // the seed holds the NaN cluster
  int steps = 0;
  const std::vector<uint8_t> mask = grey_run(v, 21, c, 4.0, nullptr, &steps);
  size_t slab_in = 0, outside_ball = 0;
  for (size_t q = 0; q < n; ++q) {
    const int64_t i = int64_t(q % size_t(dims[0]));
    slab_in += mask[q] && bad[q] && i - 32 > 16;  // the slab beyond the ball's surface
    outside_ball += mask[q] && !truth[q] && !bad[q];
  }
  const double dice = ffseg_test::dice(mask, truth);
  std::printf("non-finite voxels: Dice %.4f, %zu slab voxels beyond the ball inside, %zu voxels outside the ball, %d steps\n", dice,
              slab_in, outside_ball, steps);
  // With the cluster's voxels in the model (read as the crop's 1st
  // percentile, a background value) the object came out at Dice 0.949.
  CHECK(dice >= 0.97);
  CHECK(outside_ball == 0);
  CHECK(slab_in == 0);
}

TEST_CASE("chapter 5 on the cavity phantom does not depend on how it is stored (flips, permuted axes, type)") {
  // The i16 phantom with its rescale, and the same HU stored flipped along
  // each axis, with permuted axes, as f32 and as f64: Dice >= 0.995 (issue 19).
  const CavityPhantom ct = make_cavity_phantom();
  const std::vector<double> raw(ct.stored.begin(), ct.stored.end());
  const std::vector<ffseg_test::StoredVariant> vars =
      ffseg_test::stored_variants(ct.dims, ct.A, raw, FFSEG_I16, 1.0, -1024.0);
  const double c[3] = {-8.0, -4.0, -3.0};
  const std::vector<uint8_t> ref = ffseg_test::segment_variant(vars[0], c, 5.0, 12);
  CHECK(ffseg_test::dice(ref, ct.organ) >= 0.9);
  for (size_t v = 1; v < vars.size(); ++v) {
    CAPTURE(vars[v].name);
    const std::vector<uint8_t> m = ffseg_test::segment_variant(vars[v], c, 5.0, 12);
    const size_t differ = ffseg_test::differing_voxels(ref, m);
    if (differ > 0) std::printf("cavity phantom, %s: %zu voxels differ\n", vars[v].name.c_str(), differ);
    CHECK(ffseg_test::dice(ref, m) >= 0.995);
  }
}
