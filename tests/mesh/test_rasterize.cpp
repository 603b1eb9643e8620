// Sphere placement and rasterisation through the C API (src/mesh/rasterize.h).
#include <doctest/doctest.h>

#include "support/u8_view.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstddef>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cubesphere.h"
#include "ffseg.h"
#include "rasterize.h"
#include "support/mesh_box.h"
#include "test_util.h"
#include "volume.h"

using ffseg_test::EngineBox;
using ffseg_test::make_volume;

using ffseg_test::MeshBox;
using ffseg_test::u8_view;

TEST_CASE("sphere placement: radius exact, enclosed volume within 1%") {
  const int64_t dims[3] = {64, 64, 64};
  std::vector<float> data(64 * 64 * 64, 0.f);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  EngineBox eb(1, 33);
  ffseg_volume v = make_volume(data.data(), FFSEG_F32, dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double c[3] = {30.5, 31.25, 29.0}, r = 20.0;
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  ffseg_test::extract(eb.e, 0, &xyz, &tris);
  double maxdev = 0;
  for (size_t i = 0; i < xyz.size() / 3; ++i) {
    const double d = std::sqrt(std::pow(xyz[3 * i] - c[0], 2) + std::pow(xyz[3 * i + 1] - c[1], 2) +
                               std::pow(xyz[3 * i + 2] - c[2], 2));
    maxdev = std::max(maxdev, std::fabs(d - r));
  }
  CHECK(maxdev < 1e-4);
  const double vol = ffseg_test::signed_volume(xyz, tris);
  const double exact = 4.0 / 3.0 * M_PI * r * r * r;
  CHECK(std::fabs(vol - exact) / exact < 0.01);
}

TEST_CASE("rasterize: voxel count within 2% of 4/3 pi r^3 on an anisotropic rotated grid") {
  const int64_t dims[3] = {80, 70, 40};
  std::vector<int16_t> data(size_t(dims[0] * dims[1] * dims[2]), 0);
  // Spacing 0.7 x 0.9 x 1.6 mm, rotated 30 degrees about z, then translated.
  const double cs = std::cos(M_PI / 6), sn = std::sin(M_PI / 6);
  const double A[16] = {0.7 * cs, -0.9 * sn, 0, -10, 0.7 * sn, 0.9 * cs, 0, 5, 0, 0, 1.6, 2, 0, 0, 0, 1};
  EngineBox eb(1, 33);
  ffseg_volume v = make_volume(data.data(), FFSEG_I16, dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double ijk[3] = {40.3, 35.2, 20.1};
  double c[3];
  for (int r = 0; r < 3; ++r) c[r] = A[4 * r] * ijk[0] + A[4 * r + 1] * ijk[1] + A[4 * r + 2] * ijk[2] + A[4 * r + 3];
  const double r = 18.0;
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  std::vector<uint8_t> mask(data.size(), 7);
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  size_t count = 0, wrong = 0;
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i) {
        const uint8_t m = mask[size_t(i + dims[0] * (j + dims[1] * k))];
        REQUIRE(m <= 1);
        count += m;
        double w[3];
        for (int q = 0; q < 3; ++q) w[q] = A[4 * q] * i + A[4 * q + 1] * j + A[4 * q + 2] * k + A[4 * q + 3];
        const double d = std::sqrt(std::pow(w[0] - c[0], 2) + std::pow(w[1] - c[1], 2) + std::pow(w[2] - c[2], 2));
        // Away from the boundary the answer is exact.
        if (d < r - 0.3 && m != 1) ++wrong;
        if (d > r + 0.01 && m != 0) ++wrong;
      }
  CHECK(wrong == 0);
  const double expect = 4.0 / 3.0 * M_PI * r * r * r / (0.7 * 0.9 * 1.6);
  CHECK(std::fabs(double(count) - expect) / expect < 0.02);

  // Strided (padded, reversed k) mask gives the same voxels.
  const int64_t pad_i = 2, pad_j = dims[0] * pad_i + 16;
  const int64_t slab = pad_j * dims[1];
  std::vector<uint8_t> big(size_t(slab * dims[2]), 9);
  const int64_t strides[3] = {pad_i, pad_j, -slab};
  REQUIRE(ffseg_rasterize(eb.e, 0, big.data() + slab * (dims[2] - 1), strides) == FFSEG_OK);
  size_t same = 0;
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i)
        same += big[size_t(slab * (dims[2] - 1 - k) + pad_j * j + pad_i * i)] ==
                mask[size_t(i + dims[0] * (j + dims[1] * k))];
  CHECK(same == data.size());
  // Padding bytes are untouched.
  CHECK(big[1] == 9);
}

TEST_CASE("rasterize: a sphere far larger than the grid rasterizes without overflow") {
  // Mesh indices of +-1e20 voxels once overflowed the integer row range
  // (UBSan finding of fuzz_volume, kept as fuzz/corpus/volume/regress-rasterize-far-vertex).
  const int64_t dims[3] = {6, 5, 4};
  std::vector<uint8_t> vox(6 * 5 * 4, 1);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  ffseg_test::EngineBox eb(1, 4);
  REQUIRE(eb.e);
  const ffseg_volume v = ffseg_test::make_volume(vox.data(), FFSEG_U8, dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  const double c[3] = {2.5, 2, 1.5};
  std::vector<uint8_t> mask(vox.size(), 7);
  for (double r : {1e5, 1e20, 3e21}) {
    CAPTURE(r);
    REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
    REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
    // At 1e5 mm every voxel centre is inside; at 1e20 mm the edge functions
    // cannot resolve a 1 mm grid (they round), so only a mask of 0 and 1.
    for (uint8_t m : mask) REQUIRE((r < 1e10 ? m == 1 : m <= 1));
  }
}

TEST_CASE("rasterize: count_inside_voxels and mesh_fills_grid agree with the mask, either handedness") {
  // A bumpy, non-convex but star-shaped mesh (no self-intersection), cut by
  // the grid's walls, on an anisotropic grid with and without a mirrored axis.
  MeshBox mb(16);
  std::vector<double> x(size_t(3) * mb.m.nv);
  const double c[3] = {14.2, 11.3, 3.1};
  for (uint32_t v = 0; v < mb.m.nv; ++v) {
    const double* u = mb.m.unit + 3 * size_t(v);
    const double r = 13 * (1 + 0.3 * std::sin(3 * u[0]) * std::cos(4 * u[1]) + 0.2 * u[2] * u[2]);
    for (int a = 0; a < 3; ++a) x[3 * v + a] = c[a] + r * u[a];
  }
  const int64_t dims[3] = {30, 26, 22};
  std::vector<uint8_t> vox(size_t(dims[0] * dims[1] * dims[2]));
  for (double flip : {1.0, -1.0}) {
    CAPTURE(flip);
    const double A[16] = {0.9, 0, 0, 0, 0, 1.1 * flip, 0, flip < 0 ? 26 * 1.1 : 0, 0, 0, 1.3, -4, 0, 0, 0, 1};
    const ffseg::VolumeView view = u8_view(vox, dims, A);
    std::vector<uint8_t> mask(vox.size(), 0);
    ffseg::rasterize_mesh(mb.m, x.data(), view, mask.data(), nullptr);
    int64_t ones = 0;
    for (uint8_t b : mask) ones += b;
    const int64_t total = int64_t(vox.size());
    MESSAGE("mask " << ones << " of " << total);
    REQUIRE(ones > total / 10);  // the mesh cuts the grid, neither empty nor whole
    REQUIRE(ones < total);
    CHECK(ffseg::count_inside_voxels(mb.m, x.data(), view) == ones);
    const double f = double(ones) / double(total);
    CHECK(ffseg::mesh_fills_grid(mb.m, x.data(), view, f - 0.5 / double(total)));
    CHECK_FALSE(ffseg::mesh_fills_grid(mb.m, x.data(), view, f + 0.5 / double(total)));
  }
  // A mesh whose bounding box holds too few voxel centres is never counted
  // (a mesh beside the grid, fraction 0: still false).
  std::vector<double> away(x);
  for (size_t q = 0; q < away.size(); q += 3) away[q] += 500;
  const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const ffseg::VolumeView view = u8_view(vox, dims, I);
  CHECK(ffseg::count_inside_voxels(mb.m, away.data(), view) == 0);
  CHECK_FALSE(ffseg::mesh_fills_grid(mb.m, away.data(), view, 0.0));
}
