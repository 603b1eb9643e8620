// An organ cut by the scan's first or last slice (issue 30, a partial scan):
// the mesh ends at the grid's box, never beyond it, the organ's part inside
// the scan is segmented, and no step flips or crosses the mesh
// (src/image/grid_box.h).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "engine_volume.h"
#include "ffseg.h"
#include "image_io.h"
#include "support/phantoms.h"
#include "test_util.h"

using namespace ffseg_test;

namespace {

// The farthest a vertex of xyz lies beyond the grid's box [-0.5, dims - 0.5]
// (index units; 0 inside), for a diagonal index-to-world affine A.
double beyond_box(const std::vector<float>& xyz, const int64_t dims[3], const double A[16]) {
  double worst = 0;
  for (size_t v = 0; v < xyz.size() / 3; ++v)
    for (int a = 0; a < 3; ++a) {
      const double p = (double(xyz[3 * v + a]) - A[4 * a + 3]) / A[5 * a];
      worst = std::fmax(worst, std::fmax(-0.5 - p, p - (double(dims[a]) - 0.5)));
    }
  return worst;
}

struct CutRun {
  double dice = 0;
  int steps = 0;
  ffseg_status last = FFSEG_OK;
  size_t intersections = 0, flips = 0;
  double beyond = 0;  // the worst over every step, index units
  std::vector<uint8_t> mask;
};

// One object from a sphere, stepped to rest (at most max_steps), the mesh
// checked after every step.
CutRun run_cut(const ffseg_volume& v, const double A[16], bool binary, uint32_t n, const double c[3], double r,
               const std::vector<uint8_t>& truth, int max_steps = 150) {
  CutRun res;
  EngineBox eb(1, n, v.dims[0] * v.dims[1] * v.dims[2]);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = binary ? FFSEG_TARGET_BINARY : FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  MeshWatch watch;
  REQUIRE(watch.look(eb.e, 0));
  for (; res.steps < max_steps;) {
    res.last = ffseg_step(eb.e, nullptr);
    INFO(ffseg_last_error(eb.e));
    REQUIRE(res.last >= 0);
    ++res.steps;
    REQUIRE(watch.look(eb.e, 0));
    res.beyond = std::fmax(res.beyond, beyond_box(watch.xyz, v.dims, A));
    if (res.last != FFSEG_OK) break;
  }
  res.intersections = watch.intersections;
  res.flips = watch.flips;
  res.mask.assign(truth.size(), 0);
  REQUIRE(ffseg_rasterize(eb.e, 0, res.mask.data(), nullptr) == FFSEG_OK);
  res.dice = dice(res.mask, truth);
  return res;
}

// An ellipsoid (semi-axes 22 x 18 x 26 mm) on a 1 x 1 x 2 mm grid whose first
// slice cuts it 10 mm below its centre: binary, and as grey levels (organ
// 60, background -100, noise sigma 10, i16).
struct CutPhantom {
  int64_t dims[3] = {64, 56, 24};
  double A[16] = {1, 0, 0, -32, 0, 1, 0, -28, 0, 0, 2, -10, 0, 0, 0, 1};
  std::vector<uint8_t> mask;
  std::vector<int16_t> grey;
};

CutPhantom cut_ellipsoid() {
  CutPhantom ph;
  const size_t n = size_t(ph.dims[0] * ph.dims[1] * ph.dims[2]);
  ph.mask.resize(n);
  ph.grey.resize(n);
  std::mt19937 rng(30);
  std::normal_distribution<double> noise(0.0, 10.0);
  for (int64_t k = 0; k < ph.dims[2]; ++k)
    for (int64_t j = 0; j < ph.dims[1]; ++j)
      for (int64_t i = 0; i < ph.dims[0]; ++i) {
        const double x = ph.A[0] * i + ph.A[3], y = ph.A[5] * j + ph.A[7], z = ph.A[10] * k + ph.A[11];
        const bool in = (x / 22) * (x / 22) + (y / 18) * (y / 18) + (z / 26) * (z / 26) < 1;
        const size_t q = size_t(i + ph.dims[0] * (j + ph.dims[1] * k));
        ph.mask[q] = in;
        ph.grey[q] = int16_t(std::lround((in ? 60.0 : -100.0) + noise(rng)));
      }
  return ph;
}

}  // namespace

TEST_CASE("partial scan phantom: an ellipsoid cut by the grid's first slice, binary and grey levels") {
  const CutPhantom ph = cut_ellipsoid();
  for (bool binary : {true, false}) {
    ffseg_volume v = binary ? make_volume(ph.mask.data(), FFSEG_U8, ph.dims, ph.A)
                            : make_volume(ph.grey.data(), FFSEG_I16, ph.dims, ph.A);
    // A seed inside the cut part, and one that reaches 2 mm beyond the first
    // slice's face (z = -11 mm): on the face after the first step.
    for (double cz : {8.0, -6.0}) {
      CAPTURE(binary);
      CAPTURE(cz);
      const double c[3] = {1, -1, cz};
      const CutRun r = run_cut(v, ph.A, binary, 21, c, 7.0, ph.mask);
      std::printf("cut ellipsoid, %s, seed z %.0f mm: Dice %.3f, %d steps, beyond the box %.2g voxel, "
                  "crossings %zu, flips %zu\n",
                  binary ? "binary" : "grey levels", cz, r.dice, r.steps, r.beyond, r.intersections, r.flips);
      CHECK(r.last == FFSEG_CONVERGED);
      CHECK(r.dice >= 0.95);  // 0.96-0.98 measured
      CHECK(r.beyond <= 1e-6);
      CHECK(r.intersections == 0);
      CHECK(r.flips == 0);
    }
  }
}

namespace {

const std::string kAbdomen = std::string(FFSEG_SOURCE_DIR) + "/../shared/data/abdomen_ct";

bool have_abdomen() {
  struct stat st;
  return stat((kAbdomen + "/ct.nii.gz").c_str(), &st) == 0 && stat((kAbdomen + "/labels.nii.gz").c_str(), &st) == 0;
}

// Slices [k0, k1) of img, its affine's origin moved to slice k0.
ffseg_tools::NiftiImage crop_z(const ffseg_tools::NiftiImage& img, int k0, int k1) {
  ffseg_tools::NiftiImage out = img;
  const size_t slice = size_t(img.dims[0]) * size_t(img.dims[1]) * size_t(img.bytes_per_voxel);
  out.dims[2] = k1 - k0;
  out.data.assign(img.data.begin() + ptrdiff_t(slice * size_t(k0)), img.data.begin() + ptrdiff_t(slice * size_t(k1)));
  for (int r = 0; r < 3; ++r) out.index_to_world[4 * r + 3] += img.index_to_world[4 * r + 2] * k0;
  return out;
}

std::vector<uint8_t> label_mask(const ffseg_tools::NiftiImage& lab, int label) {
  std::vector<uint8_t> m(lab.voxel_count());
  for (size_t q = 0; q < m.size(); ++q) {
    const uint8_t* p = lab.data.data() + q * size_t(lab.bytes_per_voxel);
    double value = 0;
    if (lab.voxel_type == FFSEG_U8) {
      value = *p;
    } else if (lab.voxel_type == FFSEG_F64) {  // the reader's widening of other label types
      std::memcpy(&value, p, sizeof value);
    } else {
      FAIL("label map voxel type ", lab.voxel_type);
    }
    m[q] = value == label;
  }
  return m;
}

}  // namespace

TEST_CASE("partial scan: the shared CT's liver cut at the scan's top and bottom") {
  if (!have_abdomen()) {
    MESSAGE("skipped: " << kAbdomen << " is absent (the shared data beside the repository)");
    return;
  }
  ffseg_tools::NiftiImage ct, lab;
  ffseg_tools::ImageFormat f;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::image_read_file(kAbdomen + "/ct.nii.gz", &ct, &f, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::image_read_file(kAbdomen + "/labels.nii.gz", &lab, &f, &err), err);
  REQUIRE(ct.dims[2] == 112);
  // The whole scan (its top slice already cuts the liver, z 70..111), from
  // the liver's protocol sphere (ffseg segment --sphere-from-label).
  const std::vector<uint8_t> liver = label_mask(lab, 5);
  const ffseg_volume full_v = ffseg_tools::engine_volume(ct);
  const double full_c[3] = {95.0437, 167.319, 394.302};
  const CutRun full = run_cut(full_v, ct.index_to_world, false, 12, full_c, 17.3638, liver);
  CHECK(full.beyond <= 1e-6);
  CHECK(full.intersections == 0);
  CHECK(full.flips == 0);
  struct Cut {
    const char* name;
    int k0, k1;          // the kept slices
    double c[3], r;      // the cropped label's protocol sphere
    double dice_floor;   // against the cropped label
  };
  // The liver's top third cut off (the scan ends 1/3 down it), and its
  // lower third (the scan starts 1/3 up it).
  const Cut cuts[] = {{"top third cut off", 0, 98, {104.044, 173.319, 361.302}, 12.1861, 0.75},
                      {"bottom third cut off", 84, 112, {95.0437, 167.319, 394.302}, 17.3638, 0.80}};
  for (const Cut& cut : cuts) {
    CAPTURE(cut.name);
    const ffseg_tools::NiftiImage cct = crop_z(ct, cut.k0, cut.k1), clab = crop_z(lab, cut.k0, cut.k1);
    const std::vector<uint8_t> truth = label_mask(clab, 5);
    const CutRun r = run_cut(ffseg_tools::engine_volume(cct), cct.index_to_world, false, 12, cut.c, cut.r, truth);
    // The full scan's liver on the crop's slices, against the same label.
    const size_t slice = size_t(ct.dims[0]) * size_t(ct.dims[1]);
    const std::vector<uint8_t> full_part(full.mask.begin() + ptrdiff_t(slice * size_t(cut.k0)),
                                         full.mask.begin() + ptrdiff_t(slice * size_t(cut.k1)));
    const double full_dice = dice(full_part, truth);
    std::printf("liver, %s: Dice %.3f (the full scan's run on these slices %.3f), %d steps, beyond the box %.2g "
                "voxel, crossings %zu, flips %zu\n",
                cut.name, r.dice, full_dice, r.steps, r.beyond, r.intersections, r.flips);
    CHECK(r.last == FFSEG_CONVERGED);
    CHECK(r.dice >= cut.dice_floor);
    CHECK(r.beyond <= 1e-6);
    CHECK(r.intersections == 0);
    CHECK(r.flips == 0);
    // The edge slice itself: the cut's face holds organ, not a rounded cap
    // inside it (at least half the label's voxels of that slice).
    const int edge = cut.k0 > 0 ? 0 : cut.k1 - cut.k0 - 1;
    size_t got = 0, want = 0;
    for (size_t q = slice * size_t(edge); q < slice * size_t(edge + 1); ++q) {
      got += r.mask[q] && truth[q];
      want += truth[q];
    }
    CHECK(double(got) >= 0.5 * double(want));
  }
}
