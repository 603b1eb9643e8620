// Many objects stepped together: each converges on its own, whatever the step
// report holds (it shows only the first FFSEG_REPORT_OBJECTS objects).
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "ffseg.h"
#include "test_util.h"

namespace {

// count balls of radius r on a grid of cells 18 mm wide (1 mm voxels), and
// their centres (mm).
struct Balls {
  int64_t dims[3];
  std::vector<uint8_t> mask;
  std::vector<std::array<double, 3>> centres;
};

Balls ball_grid(int nx, int ny, int nz, int count, double r) {
  Balls b;
  const int cell = 18;
  b.dims[0] = nx * cell;
  b.dims[1] = ny * cell;
  b.dims[2] = nz * cell;
  b.mask.assign(size_t(b.dims[0] * b.dims[1] * b.dims[2]), 0);
  for (int c = 0; c < count; ++c) {
    const int i = c % nx, j = (c / nx) % ny, k = c / (nx * ny);
    // Off the voxel grid by a different fraction per ball, so no two are alike.
    const std::array<double, 3> ctr{cell * (i + 0.5) + 0.1 * (c % 3), cell * (j + 0.5) + 0.07 * (c % 5),
                                     cell * (k + 0.5) + 0.05 * (c % 7)};
    b.centres.push_back(ctr);
    for (int64_t z = 0; z < b.dims[2]; ++z)
      for (int64_t y = 0; y < b.dims[1]; ++y)
        for (int64_t x = 0; x < b.dims[0]; ++x) {
          const double dx = x - ctr[0], dy = y - ctr[1], dz = z - ctr[2];
          if (dx * dx + dy * dy + dz * dz <= r * r) b.mask[size_t((z * b.dims[1] + y) * b.dims[0] + x)] = 1;
        }
  }
  return b;
}

void grow_all(int nx, int ny, int nz, int count) {
  const double R = 6.5;
  const Balls b = ball_grid(nx, ny, nz, count, R);
  // The bound sizes each object's bounding region (thesis 6.2): a ball's box
  // grown by the 10 mm region width is 33^3 voxels at most.
  ffseg_test::EngineBox eb(uint32_t(count), 8, int64_t(1) << 16);
  REQUIRE(eb.e != nullptr);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  ffseg_volume v = ffseg_test::make_volume(b.mask.data(), FFSEG_U8, b.dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  for (int c = 0; c < count; ++c) REQUIRE(ffseg_init_sphere(eb.e, uint32_t(c), b.centres[size_t(c)].data(), 3.0) == FFSEG_OK);
  ffseg_status st = FFSEG_OK;
  int steps = 0;
  ffseg_test::MeshWatch watch;
  while (st == FFSEG_OK && steps < 150) {
    st = ffseg_step(eb.e, nullptr);
    ++steps;
    for (int c = 0; c < count; ++c) REQUIRE(watch.look(eb.e, uint32_t(c)));
  }
  CHECK(st == FFSEG_CONVERGED);
  CHECK(watch.intersections == 0);
  CHECK(watch.flips == 0);
  // Every object, the first and the last alike, reaches its own ball: its mean
  // vertex distance from the centre is the radius (within the half voxel the
  // 0.5 level of a binary ball puts it).
  for (int c = 0; c < count; ++c) {
    std::vector<float> xyz;
    std::vector<uint32_t> tris;
    REQUIRE(ffseg_test::extract(eb.e, uint32_t(c), &xyz, &tris));
    double mean = 0;
    for (size_t q = 0; q < xyz.size() / 3; ++q) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += (xyz[3 * q + a] - b.centres[size_t(c)][size_t(a)]) * (xyz[3 * q + a] - b.centres[size_t(c)][size_t(a)]);
      mean += std::sqrt(d2);
    }
    mean /= double(xyz.size() / 3);
    INFO("object ", c, " of ", count, ": mean radius ", mean, " after ", steps, " steps");
    CHECK(std::fabs(mean - R) < 0.5);
  }
}

}  // namespace

TEST_CASE("20 objects stepped together each grow to their own ball (past the report's 16 slots)") {
  grow_all(5, 4, 1, 20);
}

TEST_CASE("64 objects (the most a configuration allows) each grow to their own ball") {
  grow_all(4, 4, 4, 64);
}
