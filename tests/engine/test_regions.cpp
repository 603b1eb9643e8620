// Several objects at once (thesis chapter 6): bounding regions by fast
// marching, searches that stop at another object's region, and objects that
// never share a voxel.
#include <doctest/doctest.h>

#include "support/u8_view.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "../../capi/capi_internal.h"  // engine_of()
#include "bounding_region.h"
#include "engine.h"
#include "ffseg.h"
#include "param_table.h"
#include "support/mesh_check.h"
#include "support/phantoms.h"
#include "rasterize.h"
#include "support/sphere_box.h"
#include "test_util.h"
#include "testing.h"  // EngineTesting::set_speed_tables

namespace {

const double kIdentity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};


std::vector<uint8_t> mask_of(ffseg_engine* e, uint32_t object, const int64_t dims[3]) {
  std::vector<uint8_t> m(size_t(dims[0] * dims[1] * dims[2]));
  REQUIRE(ffseg_rasterize(e, object, m.data(), nullptr) == FFSEG_OK);
  return m;
}

// A bar of non-zero voxels 50 x 16 x 16 mm in a 70 x 30 x 30 grid (1 mm).
struct Bar {
  int64_t dims[3] = {70, 30, 30};
  std::vector<uint8_t> v;
  Bar() : v(size_t(70 * 30 * 30), 0) {
    for (int64_t k = 7; k < 23; ++k)
      for (int64_t j = 7; j < 23; ++j)
        for (int64_t i = 10; i < 60; ++i) v[size_t((k * 30 + j) * 70 + i)] = 1;
  }
  // Hands the bar to engine e as its volume (identity affine, 1 mm voxels).
  void set(ffseg_engine* e) const {
    ffseg_volume vol = ffseg_test::make_volume(v.data(), FFSEG_U8, dims, kIdentity);
    REQUIRE(ffseg_set_volume(e, &vol) == FFSEG_OK);
  }
  size_t count() const {
    size_t c = 0;
    for (uint8_t x : v) c += x;
    return c;
  }
};

struct Run {
  ffseg_status last = FFSEG_OK;
  int steps = 0;
  uint32_t max_border[2] = {0, 0};
  size_t crossings = 0, shared_voxels = 0, self = 0;
  std::vector<uint8_t> mask[2];  // each object's voxels at the end
};

// Two spheres in the bar, grown together in one engine; every step checked.
// max_region: config.max_region_voxels (0: max_roi_voxels, 2^18).
Run grow_pair(const Bar& bar, const double ca[3], const double cb[3], double r, int64_t max_region = 0) {
  Run run;
  ffseg_test::EngineBox eb(2, 12, int64_t(1) << 18, max_region);
  REQUIRE(eb.e != nullptr);
  bar.set(eb.e);
  REQUIRE(ffseg_init_sphere(eb.e, 0, ca, r) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 1, cb, r) == FFSEG_OK);
  ffseg_test::MeshWatch wa, wb;
  while (run.last == FFSEG_OK && run.steps < 150) {
    ffseg_step_info info;
    info.struct_size = sizeof info;
    run.last = ffseg_step(eb.e, &info);
    ++run.steps;
    if (run.last != FFSEG_OK && run.last != FFSEG_CONVERGED) break;
    for (int o = 0; o < 2; ++o)
      if (info.border_vertices[o] > run.max_border[o]) run.max_border[o] = info.border_vertices[o];
    REQUIRE(wa.look(eb.e, 0));
    REQUIRE(wb.look(eb.e, 1));
    run.crossings += ffseg_test::crossings_between(wa.xyz, wa.tris, wb.xyz, wb.tris);
    const std::vector<uint8_t> ma = mask_of(eb.e, 0, bar.dims), mb = mask_of(eb.e, 1, bar.dims);
    for (size_t q = 0; q < ma.size(); ++q) run.shared_voxels += ma[q] && mb[q];
    run.mask[0] = ma;
    run.mask[1] = mb;
  }
  run.self = wa.intersections + wb.intersections + wa.flips + wb.flips;
  return run;
}

}  // namespace

TEST_CASE("regions: rasterising into a box gives the grid's mask cut to the box") {
  ffseg_test::SphereBox sb(12);
  std::vector<double> x = sb.sphere(7.3);
  for (size_t q = 0; q < x.size(); q += 3) {
    x[q] += 12.4;
    x[q + 1] += 10.1;
    x[q + 2] += 9.7;
  }
  const int64_t dims[3] = {26, 22, 20};
  std::vector<uint8_t> vox(size_t(dims[0] * dims[1] * dims[2]));
  const ffseg::VolumeView view = ffseg_test::u8_view(vox, dims, kIdentity);
  std::vector<uint8_t> full(vox.size());
  ffseg::rasterize_mesh(sb.m, x.data(), view, full.data(), nullptr);
  size_t inside = 0;
  for (uint8_t b : full) inside += b;
  CHECK(inside > 1000);  // 4/3 pi 7.3^3 = 1630
  // Boxes that cut the sphere, hold it, and start past it.
  const int64_t boxes[][6] = {{0, 0, 0, 26, 22, 20}, {5, 3, 4, 10, 9, 8}, {12, 10, 9, 14, 12, 11}, {20, 0, 0, 6, 22, 20}};
  for (const auto& b : boxes) {
    const int64_t lo[3] = {b[0], b[1], b[2]}, n[3] = {b[3], b[4], b[5]};
    std::vector<uint8_t> box(size_t(n[0] * n[1] * n[2]), 7);
    const int64_t got = ffseg::rasterize_mesh_box(sb.m, x.data(), view, lo, n, box.data());
    int64_t want = 0;
    bool same = true;
    for (int64_t k = 0; k < n[2]; ++k)
      for (int64_t j = 0; j < n[1]; ++j)
        for (int64_t i = 0; i < n[0]; ++i) {
          const uint8_t f = full[size_t(((k + lo[2]) * dims[1] + j + lo[1]) * dims[0] + i + lo[0])];
          want += f;
          same = same && box[size_t((k * n[1] + j) * n[0] + i)] == f;
        }
    CAPTURE(lo[0]);
    CHECK(same);
    CHECK(got == want);
  }
}

TEST_CASE("regions: two objects in one bar split it where their fronts meet, never sharing a voxel") {
  const Bar bar;
  // Off-centre so that the fronts meet away from the middle: object 0 is
  // nearer its end of the bar, so its front reaches the middle first.
  const double ca[3] = {22.3, 15.1, 14.8}, cb[3] = {44.6, 14.9, 15.2};
  const Run run = grow_pair(bar, ca, cb, 3.0);
  MESSAGE("steps ", run.steps, " borders ", run.max_border[0], " ", run.max_border[1], " crossings ", run.crossings);
  CHECK(run.last == FFSEG_CONVERGED);
  CHECK(run.crossings == 0);
  CHECK(run.shared_voxels == 0);
  CHECK(run.self == 0);
  // Each met the other's region: border vertices on both.
  CHECK(run.max_border[0] > 0);
  CHECK(run.max_border[1] > 0);
}

TEST_CASE("regions: alone, each of the two objects fills the whole bar (what the regions prevent)") {
  // The same spheres, one engine each: both meshes take the whole bar, so
  // their masks overlap in most of it. This is what the test above guards.
  const Bar bar;
  const double centres[2][3] = {{22.3, 15.1, 14.8}, {44.6, 14.9, 15.2}};
  std::vector<uint8_t> masks[2];
  for (int o = 0; o < 2; ++o) {
    ffseg_test::EngineBox eb(1, 12);
    REQUIRE(eb.e != nullptr);
    bar.set(eb.e);
    REQUIRE(ffseg_init_sphere(eb.e, 0, centres[o], 3.0) == FFSEG_OK);
    ffseg_status st = FFSEG_OK;
    for (int s = 0; s < 150 && st == FFSEG_OK; ++s) st = ffseg_step(eb.e, nullptr);
    CHECK(st == FFSEG_CONVERGED);
    masks[o] = mask_of(eb.e, 0, bar.dims);
  }
  size_t shared = 0;
  for (size_t q = 0; q < masks[0].size(); ++q) shared += masks[0][q] && masks[1][q];
  CHECK(double(shared) > 0.5 * double(bar.count()));
}

namespace {

// Thesis fig. 6.5 as a phantom: a CT-like i16 volume (1 mm), an organ of 60 HU
// (a ball of radius 14 mm) touching a vessel of 65 HU (a cylinder of radius
// 4 mm along x through the whole volume, its axis 17 mm above the organ's
// centre, so the two overlap by 1 mm), fat of -60 HU around, Gaussian noise
// of sigma 12 HU. Labels: 1 organ, 2 vessel (the vessel wins where they meet).
struct Leak {
  int64_t dims[3] = {96, 64, 72};
  double organ[3] = {48.2, 32.1, 28.3};
  double vessel_y = 32.1, vessel_z = 28.3 + 17.0;
  std::vector<int16_t> v;
  std::vector<uint8_t> label;
  Leak() {
    const size_t n = size_t(dims[0] * dims[1] * dims[2]);
    v.resize(n);
    label.resize(n);
    uint64_t s = 0x9E3779B97F4A7C15ull;
    auto uniform = [&]() {
      s ^= s << 13, s ^= s >> 7, s ^= s << 17;
      return (double(s >> 11) + 0.5) / 9007199254740992.0;
    };
    for (int64_t k = 0; k < dims[2]; ++k)
      for (int64_t j = 0; j < dims[1]; ++j)
        for (int64_t i = 0; i < dims[0]; ++i) {
          const size_t q = size_t((k * dims[1] + j) * dims[0] + i);
          const double dx = i - organ[0], dy = j - organ[1], dz = k - organ[2];
          const double ry = j - vessel_y, rz = k - vessel_z;
          uint8_t l = 0;
          double hu = -60;
          if (ry * ry + rz * rz <= 16.0) l = 2, hu = 65;
          else if (dx * dx + dy * dy + dz * dz <= 196.0) l = 1, hu = 60;
          const double g = std::sqrt(-2 * std::log(uniform())) * std::cos(6.283185307179586 * uniform());
          v[q] = int16_t(std::lround(hu + 12 * g));
          label[q] = l;
        }
  }
};

struct LeakResult {
  double organ_dice = 0;
  double vessel_taken = 0;  // share of the vessel's voxels inside the organ's mesh
  size_t shared = 0;
  ffseg_status last = FFSEG_OK;
  int steps = 0;
};

LeakResult segment_leak(const Leak& ph, bool with_vessel) {
  ffseg_test::EngineBox eb(with_vessel ? 2 : 1, 12);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume vol = ffseg_test::make_volume(ph.v.data(), FFSEG_I16, ph.dims, kIdentity);
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, ph.organ, 6.0) == FFSEG_OK);
  if (with_vessel) {
    const double c[3] = {ph.organ[0], ph.vessel_y, ph.vessel_z + 0.5};
    REQUIRE(ffseg_init_sphere(eb.e, 1, c, 2.5) == FFSEG_OK);
  }
  LeakResult res;
  // The vessel's grey level is rare in the box around its sphere and unlike
  // the fat's, so it grows freely along the vessel (grey_respacing's
  // automatic setting), which takes more steps than the organ needs.
  for (; res.steps < 600 && res.last == FFSEG_OK; ++res.steps) res.last = ffseg_step(eb.e, nullptr);
  const std::vector<uint8_t> organ = mask_of(eb.e, 0, ph.dims);
  std::vector<uint8_t> vessel;
  if (with_vessel) vessel = mask_of(eb.e, 1, ph.dims);
  size_t a = 0, b = 0, ab = 0, vessel_voxels = 0, taken = 0;
  for (size_t q = 0; q < organ.size(); ++q) {
    a += organ[q];
    b += ph.label[q] == 1;
    ab += organ[q] && ph.label[q] == 1;
    vessel_voxels += ph.label[q] == 2;
    taken += organ[q] && ph.label[q] == 2;
    if (with_vessel) res.shared += organ[q] && vessel[q];
  }
  res.organ_dice = 2.0 * double(ab) / double(a + b);
  res.vessel_taken = double(taken) / double(vessel_voxels);
  return res;
}

}  // namespace

TEST_CASE("regions: the thesis' leakage case (fig. 6.5): alone the organ leaks along the vessel, with it it does not") {
  const Leak ph;
  const LeakResult alone = segment_leak(ph, false);
  MESSAGE("alone: organ Dice ", alone.organ_dice, ", vessel taken ", alone.vessel_taken);
  CHECK(alone.vessel_taken > 0.10);  // the leak the regions must stop
  const LeakResult both = segment_leak(ph, true);
  MESSAGE("with the vessel: organ Dice ", both.organ_dice, ", vessel taken ", both.vessel_taken, ", shared voxels ",
          both.shared, ", ", both.steps, " steps");
  CHECK(both.last == FFSEG_CONVERGED);
  CHECK(both.vessel_taken <= 0.02);
  CHECK(both.organ_dice >= 0.90);
  CHECK(both.shared == 0);
}

TEST_CASE("regions: a box over max_region_voxels is marched on cells; the bar splits as on voxels, never shared") {
  // 6 mm spheres grown by the 10 mm region width: boxes of about 27^3 voxels.
  // 2^12 voxels hold them on cells of 2 voxels (as the 1 mm abdomen's liver
  // and spleen under the tool's 400 MB), so the regions are coarser but the
  // pair segments as before: the border where the fronts meet moves by at
  // most about a cell, in objects some 25 voxels long.
  const Bar bar;
  const double ca[3] = {22.3, 15.1, 14.8}, cb[3] = {44.6, 14.9, 15.2};
  const Run fine = grow_pair(bar, ca, cb, 3.0);
  const Run cells = grow_pair(bar, ca, cb, 3.0, int64_t(1) << 12);
  MESSAGE("steps ", cells.steps, " borders ", cells.max_border[0], " ", cells.max_border[1]);
  CHECK(cells.last == FFSEG_CONVERGED);
  CHECK(cells.crossings == 0);
  CHECK(cells.shared_voxels == 0);
  CHECK(cells.self == 0);
  CHECK(cells.max_border[0] > 0);
  CHECK(cells.max_border[1] > 0);
  for (int o = 0; o < 2; ++o) {
    const double d = ffseg_test::dice(fine.mask[o], cells.mask[o]);
    CAPTURE(o);
    CAPTURE(d);
    CHECK(d >= 0.95);  // measured 0.966 and 0.968: the border moved by about a voxel
  }
}

TEST_CASE("regions: a box that fits max_region_voxels only on cells coarser than half the width is FFSEG_ERR_ROI_TOO_LARGE; meshes unchanged") {
  // Binary targets carve no smoothed crop, so only the regions need the
  // bound: 2^6 cells cannot hold a 6 mm sphere's box grown by 10 mm on cells
  // of at most 5 mm.
  const Bar bar;
  ffseg_test::EngineBox eb(2, 8, int64_t(1) << 12, int64_t(1) << 6);
  REQUIRE(eb.e != nullptr);
  bar.set(eb.e);
  const double ca[3] = {22.3, 15.1, 14.8}, cb[3] = {44.6, 14.9, 15.2};
  REQUIRE(ffseg_init_sphere(eb.e, 0, ca, 3.0) == FFSEG_OK);
  // One object: no region, the bound is not needed.
  CHECK(ffseg_step(eb.e, nullptr) == FFSEG_OK);
  std::vector<float> before, after;
  std::vector<uint32_t> tris;
  REQUIRE(ffseg_test::extract(eb.e, 0, &before, &tris));
  REQUIRE(ffseg_init_sphere(eb.e, 1, cb, 3.0) == FFSEG_OK);
  CHECK(ffseg_step(eb.e, nullptr) == FFSEG_ERR_ROI_TOO_LARGE);
  const std::string msg = ffseg_last_error(eb.e);
  CAPTURE(msg);
  CHECK(msg.find("region budget of 64 voxels") != std::string::npos);
  CHECK(msg.find("max_region_voxels") != std::string::npos);
  REQUIRE(ffseg_test::extract(eb.e, 0, &after, &tris));
  CHECK(before == after);
}

TEST_CASE("regions: the cells of a box are the finest that fit, near cubic in mm, aligned with the grid") {
  int64_t f[3];
  const int64_t lo[3] = {5, 7, 0}, n[3] = {100, 100, 100};
  const double iso[3] = {1, 1, 1}, ct[3] = {0.7, 0.7, 5.0};
  CHECK(ffseg::region_cells(lo, n, iso, 1000000, 5, f));
  CHECK((f[0] == 1 && f[1] == 1 && f[2] == 1));
  // 10^6 voxels in 125 000 cells: cells of 2 number 51 x 51 x 50 with the
  // grid's alignment (the box starts inside a cell), too many; so 3.
  CHECK(ffseg::region_cells(lo, n, iso, 125000, 5, f));
  CHECK((f[0] == 3 && f[1] == 3 && f[2] == 3));
  // On 0.7 x 0.7 x 5 mm slices stay whole until the cells reach 5 mm in-plane.
  const int64_t m[3] = {400, 400, 40};
  CHECK(ffseg::region_cells(lo, m, ct, 40 * 201 * 201, 10, f));
  CHECK((f[0] == 2 && f[1] == 2 && f[2] == 1));
  CHECK(ffseg::region_cells(lo, m, ct, 40 * 60 * 60, 10, f));
  CHECK((f[0] == 7 && f[1] == 7 && f[2] == 1));  // 4.9 mm in-plane
  // Coarser than the limit: refused.
  CHECK_FALSE(ffseg::region_cells(lo, n, iso, 1000, 5, f));
  CHECK(ffseg::region_cells(lo, n, iso, 1000, 12, f));
  // Spacings orders of magnitude apart (a hostile affine): the answer comes
  // at once, the fine axis in one cell (a walk one step of c at a time took
  // 12 s at 1e-8 mm and never ended at 1e-12).
  const int64_t flat[3] = {4, 50, 50};
  const double wild[3] = {1e-12, 1, 1};
  CHECK(ffseg::region_cells(lo, flat, wild, 100, 1e300, f));
  CHECK((f[0] == 9 && f[1] == 6 && f[2] == 6));  // lo 5 + 4 voxels: one cell of 9
  CHECK_FALSE(ffseg::region_cells(lo, flat, wild, 100, 4.5, f));
  // Spacings that overflowed to infinity: no cell size can be derived (c h_min
  // / h_a is NaN), so the voxels stay single cells, here too many.
  const double inf = HUGE_VAL, lost[3] = {inf, inf, inf};
  CHECK_FALSE(ffseg::region_cells(lo, flat, lost, 100, 1e300, f));
  CHECK((f[0] == 1 && f[1] == 1 && f[2] == 1));
}

TEST_CASE("regions: a cell grid maps each cell to the centre of its voxels, both ways") {
  const int64_t dims[3] = {11, 9, 7};
  std::vector<uint8_t> vox(size_t(dims[0] * dims[1] * dims[2]));
  const double oblique[16] = {0.6, 0.8, 0, 3, -0.8, 0.6, 0, -2, 0, 0, 2.5, 1, 0, 0, 0, 1};
  const ffseg::VolumeView view = ffseg_test::u8_view(vox, dims, oblique);
  const int64_t f[3] = {2, 3, 1};
  const ffseg::VolumeView cells = view.cell_geometry(f);
  CHECK(cells.dims()[0] == 6);
  CHECK(cells.dims()[1] == 3);
  CHECK(cells.dims()[2] == 7);
  CHECK(cells.spacing()[0] == doctest::Approx(2.0));
  CHECK(cells.spacing()[1] == doctest::Approx(3.0));
  CHECK(cells.spacing()[2] == doctest::Approx(2.5));
  CHECK_FALSE(cells.valid());
  const double c[3] = {4, 2, 5}, centre[3] = {8.5, 7, 5};  // f c + (f - 1) / 2
  double wc[3], wv[3], back[3];
  cells.index_to_world(c, wc);
  view.index_to_world(centre, wv);
  cells.world_to_index(wv, back);
  for (int a = 0; a < 3; ++a) {
    CHECK(wc[a] == doctest::Approx(wv[a]));
    CHECK(back[a] == doctest::Approx(c[a]));
  }
}

TEST_CASE("regions: a sphere that overlaps a placed object is refused, naming it; apart it is placed") {
  const Bar bar;
  ffseg_test::EngineBox eb(3, 8, int64_t(1) << 18);
  REQUIRE(eb.e != nullptr);
  bar.set(eb.e);
  const double a[3] = {22.3, 15.1, 14.8};
  REQUIRE(ffseg_init_sphere(eb.e, 0, a, 4.0) == FFSEG_OK);
  const double crossing[3] = {27.0, 15.0, 15.0};   // 4.7 mm apart, radii 4 + 3: the surfaces cross
  const double inside[3] = {22.0, 15.0, 15.0};     // wholly inside object 0
  const double around[3] = {22.3, 15.1, 14.8};     // encloses object 0 (r = 6)
  CHECK(ffseg_init_sphere(eb.e, 2, crossing, 3.0) == FFSEG_ERR_INVALID_ARGUMENT);
  std::string msg = ffseg_last_error(eb.e);
  CAPTURE(msg);
  CHECK(msg.find("overlaps object 0") != std::string::npos);
  CHECK(ffseg_init_sphere(eb.e, 2, inside, 1.0) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(ffseg_init_sphere(eb.e, 2, around, 6.0) == FFSEG_ERR_INVALID_ARGUMENT);
  // Refused spheres leave nothing placed.
  CHECK(ffseg_extract_mesh(eb.e, 2, nullptr, 0, nullptr, 0, nullptr, nullptr) == FFSEG_ERR_MISUSE);
  const double apart[3] = {44.6, 14.9, 15.2};
  CHECK(ffseg_init_sphere(eb.e, 2, apart, 3.0) == FFSEG_OK);
  // Placing object 0 again where it was is not an overlap with itself.
  CHECK(ffseg_init_sphere(eb.e, 0, a, 4.5) == FFSEG_OK);
}

TEST_CASE("regions: a sphere of 1e300 mm beside a stepped object is refused without undefined arithmetic") {
  // Fuzz finding (fuzz/open/calls_obstacle_grid_inf): the overlap test's grid
  // converted coordinates of 1e300 mm to integer cells (undefined; UBSan
  // aborts). Such a sphere encloses the placed object: refused.
  const Bar bar;
  ffseg_test::EngineBox eb(2, 8, int64_t(1) << 18);
  REQUIRE(eb.e != nullptr);
  bar.set(eb.e);
  const double a[3] = {22.3, 15.1, 14.8}, b[3] = {44.6, 14.9, 15.2};
  REQUIRE(ffseg_init_sphere(eb.e, 0, a, 3.0) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 1, b, 3.0) == FFSEG_OK);
  for (int s = 0; s < 3; ++s) REQUIRE(ffseg_step(eb.e, nullptr) >= 0);
  CHECK(ffseg_init_sphere(eb.e, 1, b, 1e300) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(ffseg_init_sphere(eb.e, 1, b, 1.0) == FFSEG_OK);  // inside its own old place: no overlap with object 0
  CHECK(ffseg_step(eb.e, nullptr) >= 0);
}

namespace {
// Sets the field of ffseg_params named by a row of the parameter table.
void set_field(ffseg_params& p, const char* field, double v) {
#define FFSEG_SET_FIELD(name, ctype, kind, def, lo, hi, bounds, unit, doc) \
  if (std::strcmp(field, #name) == 0) p.name = decltype(p.name)(v);
  FFSEG_PARAM_TABLE(FFSEG_SET_FIELD)
#undef FFSEG_SET_FIELD
}

// The values at and next to each end of a row's range that the range admits.
std::vector<double> range_ends(const ffseg::ParamSpec& s) {
  const bool u32 = s.kind == ffseg::ParamKind::U32;
  const double cand[] = {s.lo, u32 ? s.lo + 1 : std::nextafter(s.lo, s.hi), u32 ? s.hi - 1 : std::nextafter(s.hi, s.lo),
                         s.hi};
  std::vector<double> out;
  for (double v : cand)
    if (ffseg::param_in_range(s, v) && std::find(out.begin(), out.end(), v) == out.end()) out.push_back(v);
  return out;
}

// Two spheres in contact in the bar under params p, up to 12 steps: every step
// either moves the meshes to finite positions with no flip, crossing or
// shared voxel, or refuses with a documented status and leaves them as they
// were.
struct CheckedRun {
  int refused = 0;       // steps refused, meshes unchanged
  uint32_t borders = 0;  // most border vertices of the two at any step: the meshes met each other's regions
};
CheckedRun run_pair_checked(const Bar& bar, const ffseg_params& p) {
  const double ca[3] = {22.3, 15.1, 14.8}, cb[3] = {44.6, 14.9, 15.2};
  ffseg_test::EngineBox eb(2, 4, int64_t(1) << 18);
  REQUIRE(eb.e != nullptr);
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  bar.set(eb.e);
  REQUIRE(ffseg_init_sphere(eb.e, 0, ca, 6.0) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 1, cb, 6.0) == FFSEG_OK);
  ffseg_test::MeshWatch wa, wb;
  REQUIRE(wa.look(eb.e, 0));
  REQUIRE(wb.look(eb.e, 1));
  ffseg_status st = FFSEG_OK;
  size_t bad = 0, shared = 0;
  CheckedRun run;
  for (int step = 0; st == FFSEG_OK && step < 12; ++step) {
    const std::vector<float> before_a = wa.xyz, before_b = wb.xyz;
    ffseg_step_info info;
    info.struct_size = sizeof info;
    st = ffseg_step(eb.e, &info);
    if (st >= 0) run.borders = std::max(run.borders, info.border_vertices[0] + info.border_vertices[1]);
    REQUIRE(wa.look(eb.e, 0));
    REQUIRE(wb.look(eb.e, 1));
    for (float f : wa.xyz) bad += !std::isfinite(f);
    for (float f : wb.xyz) bad += !std::isfinite(f);
    if (st < 0) {
      ++run.refused;
      CHECK((st == FFSEG_ERR_NUMERIC || (p.target_mode == FFSEG_TARGET_INTENSITY && st == FFSEG_ERR_SPHERE_OUTSIDE)));
      CHECK(wa.xyz == before_a);
      CHECK(wb.xyz == before_b);
    }
    const std::vector<uint8_t> ma = mask_of(eb.e, 0, bar.dims), mb = mask_of(eb.e, 1, bar.dims);
    for (size_t q = 0; q < ma.size(); ++q) shared += ma[q] && mb[q];
  }
  CHECK(bad == 0);
  CHECK(shared == 0);
  CHECK(wa.flips + wb.flips + wa.intersections + wb.intersections == 0);
  return run;
}

const ffseg::ParamSpec& spec_named(const char* name) {
  for (const ffseg::ParamSpec& s : ffseg::kParamSpecs)
    if (std::strcmp(s.name, name) == 0) return s;
  FAIL("no such parameter");
  return ffseg::kParamSpecs[0];
}
}  // namespace

TEST_CASE("regions: every parameter at each end of its range, and the weights' small ends in pairs, give finite meshes") {
  // Finding 6 was two values inside their documented ranges
  // (lambda_position 4.9e-324, border_weight 0.5) whose product the solve
  // could not hold. Each row of the table alone at the ends of its range
  // (and the representable values next to them), then every pair of the
  // weights that multiply one another at their small ends, with two objects
  // in contact and both targets (run_pair_checked).
  const Bar bar;
  int runs = 0, refusals = 0, met = 0;
  auto tally = [&](const CheckedRun& r) {
    ++runs;
    refusals += r.refused;
    met += r.borders > 0;
  };
  const uint32_t modes[] = {FFSEG_TARGET_BINARY, FFSEG_TARGET_INTENSITY};
  for (const ffseg::ParamSpec& s : ffseg::kParamSpecs) {
    if (std::strcmp(s.name, "target_mode") == 0) continue;  // the loop below sets it
    for (double v : range_ends(s))
      for (uint32_t mode : modes) {
        const std::string field = s.name;
        CAPTURE(field);
        CAPTURE(v);
        CAPTURE(mode);
        ffseg_params p;
        ffseg_params_init_default(&p);
        p.target_mode = mode;
        set_field(p, s.name, v);
        tally(run_pair_checked(bar, p));
      }
  }
  const char* weights[] = {"lambda_laplacian", "lambda_position", "lambda_uniform", "border_weight", "step_size"};
  for (size_t i = 0; i < 5; ++i)
    for (size_t j = i + 1; j < 5; ++j) {
      const std::vector<double> a = range_ends(spec_named(weights[i])), b = range_ends(spec_named(weights[j]));
      for (size_t ia = 0; ia < 2; ++ia)
        for (size_t ib = 0; ib < 2; ++ib)
          for (uint32_t mode : modes) {
            const std::string first = weights[i], second = weights[j];
            CAPTURE(first);
            CAPTURE(a[ia]);
            CAPTURE(second);
            CAPTURE(b[ib]);
            CAPTURE(mode);
            ffseg_params p;
            ffseg_params_init_default(&p);
            p.target_mode = mode;
            set_field(p, weights[i], a[ia]);
            set_field(p, weights[j], b[ib]);
            tally(run_pair_checked(bar, p));
          }
    }
  MESSAGE(runs, " runs, ", met, " with the meshes in contact, ", refusals, " steps refused with the meshes unchanged");
  CHECK(runs > 200);
  CHECK(met * 2 > runs);  // most runs take the border path
}

TEST_CASE("regions: at the corners of the weights' ranges every vertex stays finite, with no flip or crossing") {
  // The ratio corners the small-end pairs above do not reach: the smallest
  // lambda_position against the largest lambda_laplacian, lambda_uniform and
  // border_weight, and the reverse; both targets.
  struct Corner {
    double lp, ll, lu, bw;
    uint32_t mode;
  };
  const Corner corners[] = {
      {1e-6, 1, 0.25, 1000, FFSEG_TARGET_BINARY},     {1e-6, 1e6, 0.25, 1000, FFSEG_TARGET_BINARY},
      {1e-6, 1e6, 1e6, 1e-300, FFSEG_TARGET_BINARY},  {1e6, 1e-300, 0, 1e9, FFSEG_TARGET_BINARY},
      {1e-6, 0.5, 0.5, 0.5, FFSEG_TARGET_INTENSITY},  {1e-6, 1e6, 0, 1e9, FFSEG_TARGET_INTENSITY},
  };
  const Bar bar;
  for (const Corner& c : corners) {
    CAPTURE(c.lp);
    CAPTURE(c.ll);
    CAPTURE(c.lu);
    CAPTURE(c.bw);
    CAPTURE(c.mode);
    ffseg_params p;
    ffseg_params_init_default(&p);
    p.lambda_position = c.lp;
    p.lambda_laplacian = c.ll;
    p.lambda_uniform = c.lu;
    p.border_weight = c.bw;
    p.target_mode = c.mode;
    const CheckedRun r = run_pair_checked(bar, p);
    CHECK(r.borders > 0);  // the meshes met each other's regions: finding 6's path (border targets) was taken
  }
}

namespace {

// Two grey-level objects in a bar of two levels (200 where i < 35, 120
// beyond, 20 around it; noise-free, so that every region's box reads the
// same value range, 20..200, and a kept table is taken whenever its epoch
// allows), stepped 6 times; object 1 then placed again in the background under the bar, so
// that its model is fitted again to another grey level, and both stepped 6
// more. Their bounding regions and vertices at the end.
std::vector<float> regions_and_vertices_after_a_refit(ffseg::EngineTesting::SpeedTables tables) {
  const int64_t dims[3] = {70, 30, 30};
  std::vector<uint8_t> v(size_t(dims[0] * dims[1] * dims[2]));
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i) {
        const bool bar = i >= 10 && i < 60 && j >= 7 && j < 23 && k >= 7 && k < 23;
        v[size_t((k * dims[1] + j) * dims[0] + i)] = uint8_t(bar ? (i < 35 ? 200 : 120) : 20);
      }
  ffseg_test::EngineBox eb(2, 12, int64_t(1) << 18);
  REQUIRE(eb.e != nullptr);
  ffseg::EngineTesting::set_speed_tables(*ffseg::capi::engine_of(eb.e), tables);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  p.sigma_floor_fraction = 0.3;  // classes wide enough that 200 and 120 compete for the voxels between
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume vol = ffseg_test::make_volume(v.data(), FFSEG_U8, dims, kIdentity);
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  const double c0[3] = {22.3, 15.1, 14.8}, c1[3] = {47.6, 14.9, 15.2};
  REQUIRE(ffseg_init_sphere(eb.e, 0, c0, 3.0) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 1, c1, 3.0) == FFSEG_OK);
  for (int s = 0; s < 6; ++s) REQUIRE(ffseg_step(eb.e, nullptr) >= 0);
  const double below[3] = {47.6, 14.9, 3.5};  // in the background under the bar: another grey level
  REQUIRE(ffseg_init_sphere(eb.e, 1, below, 2.5) == FFSEG_OK);
  for (int s = 0; s < 6; ++s) REQUIRE(ffseg_step(eb.e, nullptr) >= 0);
  std::vector<float> all;
  for (uint32_t o = 0; o < 2; ++o) {
    std::vector<uint8_t> region(v.size());
    REQUIRE(ffseg_region_mask(eb.e, o, region.data(), nullptr) == FFSEG_OK);
    all.insert(all.end(), region.begin(), region.end());
    size_t nv = 0, nt = 0;
    REQUIRE(ffseg_extract_mesh(eb.e, o, nullptr, 0, nullptr, 0, &nv, &nt) == FFSEG_OK);
    std::vector<float> xyz(nv * 3);
    std::vector<uint32_t> tris(nt * 3);
    REQUIRE(ffseg_extract_mesh(eb.e, o, xyz.data(), nv, tris.data(), nt, &nv, &nt) == FFSEG_OK);
    all.insert(all.end(), xyz.begin(), xyz.end());
  }
  return all;
}

}  // namespace

TEST_CASE("regions: a kept speed table is made again when a model changes: the same regions and meshes, bit for bit, as with none kept") {
  using T = ffseg::EngineTesting::SpeedTables;
  const std::vector<float> kept = regions_and_vertices_after_a_refit(T::kept), none = regions_and_vertices_after_a_refit(T::none);
  REQUIRE(kept.size() == none.size());
  CHECK(std::memcmp(kept.data(), none.data(), kept.size() * sizeof(float)) == 0);
  // A table kept across the refit (object 0's speed competes with object
  // 1's old model, object 1's is its old model's) gives other regions: the
  // comparison above would see a missed invalidation.
  const std::vector<float> stale = regions_and_vertices_after_a_refit(T::stale);
  REQUIRE(stale.size() == none.size());
  CHECK(std::memcmp(stale.data(), none.data(), stale.size() * sizeof(float)) != 0);
}
