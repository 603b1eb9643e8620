// The CLI's automatic mesh resolution (tools/cli/mesh_resolution.h): the
// sides of a stretched mesh ask for more than its area does.
#include <doctest/doctest.h>

#include <cstdint>
#include <vector>

#include "cli/mesh_resolution.h"

using namespace ffseg_cli;

namespace {

// A flat grid of nx x ny quads, dx by dy mm, each split into two triangles.
void quad_grid(int nx, int ny, double dx, double dy, std::vector<float>* xyz, std::vector<uint32_t>* tris) {
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      xyz->push_back(float(i * dx));
      xyz->push_back(float(j * dy));
      xyz->push_back(0.f);
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const uint32_t a = uint32_t(j * (nx + 1) + i), b = a + 1, c = a + uint32_t(nx) + 1, d = c + 1;
      for (uint32_t v : {a, b, d, a, d, c}) tris->push_back(v);
    }
}

}  // namespace

TEST_CASE("mesh resolution: quad sides, not the diagonals, and their quantiles") {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  quad_grid(4, 4, 1.0, 3.0, &xyz, &tris);  // sides of 1 and 3 mm, diagonals of 3.16
  CHECK(quad_side_quantile_mm(xyz, tris, 0.0) == doctest::Approx(1.0));
  CHECK(quad_side_quantile_mm(xyz, tris, 0.25) == doctest::Approx(1.0));
  CHECK(quad_side_quantile_mm(xyz, tris, 0.75) == doctest::Approx(3.0));
  CHECK(quad_side_quantile_mm(xyz, tris, 1.0) == doctest::Approx(3.0));
  CHECK(quad_side_quantile_mm(xyz, {}, 0.75) == 0.0);
}

TEST_CASE("mesh resolution: stretched sides ask for the resolution that makes them 1.5 voxels") {
  // 4.5 mm sides at n = 12 on a 1 mm grid: 1.5 mm at n = 36.
  CHECK(resolution_for_sides(4.5, 12, 1.0) == 36u);
  CHECK(resolution_for_sides(4.6, 12, 1.0) == 37u);
  // Never below the first run's, never above the cap.
  CHECK(resolution_for_sides(1.0, 12, 1.0) == kFirstResolution);
  CHECK(resolution_for_sides(40.0, 12, 1.0) == kMaxAutoResolution);
  CHECK(resolution_for_sides(0.0, 12, 1.0) == kFirstResolution);
  // The same stretched mesh's area asks for less: 6 faces of 12 x 12 quads
  // of 1.5 x 4.5 mm ask for ceil(sqrt(A / 6) / 1.5) = 21.
  const double area = 6 * 144 * 1.5 * 4.5;
  CHECK(resolution_for_area(area, 1.0) == 21u);
  CHECK(resolution_for_sides(4.5, 12, 1.0) > resolution_for_area(area, 1.0));
}
