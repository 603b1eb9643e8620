// The binary correspondence search (thesis 4.2.2, src/deform/binary_search.h):
// the first crossing of the indicator's 0.5 level along the normal, outward
// from inside and inward from outside, found to a fraction of a voxel; beyond
// the grid is background; no crossing within the range leaves the vertex
// solitary. Hand-made label volumes with a known boundary.
#include <doctest/doctest.h>

#include <cmath>
#include <array>
#include <cstring>
#include <vector>

#include "binary_search.h"
#include "volume.h"

namespace {

// A contiguous uint8 label volume with index_to_world = diag(s) + origin o.
struct Labels {
  std::vector<uint8_t> data;
  int64_t dims[3];
  ffseg::VolumeView view;
  Labels(int64_t nx, int64_t ny, int64_t nz) : data(size_t(nx * ny * nz), 0), dims{nx, ny, nz} {}
  uint8_t& at(int64_t i, int64_t j, int64_t k) { return data[size_t(i + dims[0] * (j + dims[1] * k))]; }
  bool finish(const double s[3], const double o[3]) {
    ffseg::VolumeDesc d;
    std::memset(&d, 0, sizeof d);
    d.type = uint32_t(ffseg::VoxelType::U8);
    d.data = data.data();
    d.data_bytes = data.size();
    for (int a = 0; a < 3; ++a) d.dims[a] = dims[a];
    d.strides[0] = 1;
    d.strides[1] = dims[0];
    d.strides[2] = dims[0] * dims[1];
    const double A[16] = {s[0], 0, 0, o[0], 0, s[1], 0, o[1], 0, 0, s[2], o[2], 0, 0, 0, 1};
    std::memcpy(d.index_to_world, A, sizeof A);
    d.slope = 1;
    d.intercept = 0;
    char msg[256];
    return view.assign(d, msg, sizeof msg);
  }
};

struct Hit {
  bool has;
  double t[3];
};

Hit search_one(const ffseg::VolumeView& vol, const double x[3], const double nrm[3], double range, double step) {
  ffseg::SearchSettings s;
  s.range_mm = range;
  s.step_mm = step;
  Hit h{};
  uint8_t has = 7;
  const uint32_t found = ffseg::search_binary(vol, 1, x, nrm, s, h.t, &has);
  CHECK(found == has);
  h.has = has != 0;
  return h;
}

// Bisection: six halvings of a step of 0.5 mm leave the crossing within
// 0.5 / 128 mm of the bracket's midpoint.
constexpr double kTol = 0.5 / 128 + 1e-12;

}  // namespace

TEST_CASE("binary search: a half-space at a sub-voxel world position, found outward and inward") {
  // Voxels i <= 9 set; spacing 0.7 mm along x, origin 0.3 mm: the 0.5 level of
  // the trilinear indicator lies at index 9.5, world x = 0.3 + 9.5 * 0.7 = 6.95.
  Labels L(24, 12, 12);
  for (int64_t k = 0; k < 12; ++k)
    for (int64_t j = 0; j < 12; ++j)
      for (int64_t i = 0; i <= 9; ++i) L.at(i, j, k) = 1;
  const double s[3] = {0.7, 1.0, 1.0}, o[3] = {0.3, 0, 0};
  REQUIRE(L.finish(s, o));
  const double xb = 0.3 + 9.5 * 0.7;
  REQUIRE(ffseg::indicator_linear(L.view, std::array<double, 3>{9.5, 5, 5}.data()) == doctest::Approx(0.5));
  const double nx[3] = {1, 0, 0};
  {  // inside, normal towards the boundary: outward, 3.3 mm away
    const double x[3] = {xb - 3.3, 5.2, 6.1};
    const Hit h = search_one(L.view, x, nx, 20, 0.5);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - xb) <= kTol);
    CHECK(h.t[1] == 5.2);
    CHECK(h.t[2] == 6.1);
  }
  {  // inside, normal away from the boundary: outward along the normal finds nothing
    const double x[3] = {xb - 3.3, 5.2, 6.1}, mx[3] = {-1, 0, 0};
    // Walking -x from index 4.8 leaves the grid at index -0.5: beyond is background.
    const Hit h = search_one(L.view, x, mx, 20, 0.5);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - (0.3 - 0.5 * 0.7)) <= kTol);
  }
  {  // outside, normal pointing away from the object: inward (against the normal)
    const double x[3] = {xb + 4.05, 7.0, 3.0};
    const Hit h = search_one(L.view, x, nx, 20, 0.5);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - xb) <= kTol);
  }
  {  // outside, oblique normal: the crossing along the line, x at the boundary
    const double r = 1 / std::sqrt(2.0);
    const double x[3] = {xb + 2.0, 4.0, 6.0}, d[3] = {r, r, 0};
    const Hit h = search_one(L.view, x, d, 20, 0.5);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - xb) <= kTol);
    CHECK(h.t[1] - 4.0 == doctest::Approx(h.t[0] - x[0]).epsilon(1e-12));
  }
  {  // a finer step: a finer result
    const double x[3] = {xb - 3.3, 5.2, 6.1};
    const Hit h = search_one(L.view, x, nx, 20, 0.05);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - xb) <= 0.05 / 128 + 1e-12);
  }
}

TEST_CASE("binary search: beyond the grid is background, no crossing within the range is solitary") {
  // Every voxel set: the object's surface is the grid's, half a voxel out.
  Labels L(10, 10, 10);
  for (auto& v : L.data) v = 1;
  const double s[3] = {1, 1, 1}, o[3] = {0, 0, 0};
  REQUIRE(L.finish(s, o));
  const double nx[3] = {1, 0, 0};
  {  // from inside, outward: exits at index 9.5
    const double x[3] = {6.0, 4.5, 4.5};
    const Hit h = search_one(L.view, x, nx, 20, 0.5);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - 9.5) <= kTol);
  }
  {  // from beyond the grid (outside), inward: enters at 9.5
    const double x[3] = {16.0, 4.5, 4.5};
    const Hit h = search_one(L.view, x, nx, 20, 0.5);
    REQUIRE(h.has);
    CHECK(std::fabs(h.t[0] - 9.5) <= kTol);
  }
  {  // the crossing 3.5 mm away: a range of 3 finds nothing, 4 finds it
    const double x[3] = {6.0, 4.5, 4.5};
    const Hit h3 = search_one(L.view, x, nx, 3.0, 0.5);
    CHECK_FALSE(h3.has);
    const Hit h4 = search_one(L.view, x, nx, 4.0, 0.5);
    CHECK(h4.has);
    // A range that is not a multiple of the step ends at the range exactly.
    const Hit h35 = search_one(L.view, x, nx, 3.6, 0.5);
    CHECK(h35.has);
    CHECK(std::fabs(h35.t[0] - 9.5) <= kTol);
    const Hit h34 = search_one(L.view, x, nx, 3.4, 0.5);
    CHECK_FALSE(h34.has);
    // The crossing 3.8 mm away: the last sample, at the range 3.6, is still
    // inside; the search does not look a whole step (to 4.0) beyond it.
    const double x2[3] = {5.7, 4.5, 4.5};
    CHECK_FALSE(search_one(L.view, x2, nx, 3.6, 0.5).has);
    CHECK(search_one(L.view, x2, nx, 3.85, 0.5).has);
  }
  {  // far beyond the grid, nothing within the range: solitary
    const double x[3] = {60.0, 4.5, 4.5};
    const Hit h = search_one(L.view, x, nx, 20, 0.5);
    CHECK_FALSE(h.has);
  }
}

TEST_CASE("binary search: a ball of known radius from its centre and from outside, several vertices at once") {
  // A ball of radius 6.3 voxels around (16, 16, 16): along an axis from the
  // centre the labels end at index 16 + 6 (|i - 16| <= 6.3), the 0.5 level
  // lies at 22.5.
  Labels L(33, 33, 33);
  for (int64_t k = 0; k < 33; ++k)
    for (int64_t j = 0; j < 33; ++j)
      for (int64_t i = 0; i < 33; ++i) {
        const double r2 = double((i - 16) * (i - 16) + (j - 16) * (j - 16) + (k - 16) * (k - 16));
        L.at(i, j, k) = r2 <= 6.3 * 6.3;
      }
  const double s[3] = {1, 1, 1}, o[3] = {0, 0, 0};
  REQUIRE(L.finish(s, o));
  // Four vertices: inside moving +x and -y, outside moving in along +z, -x.
  const double x[12] = {16, 16, 16, 16, 15.5, 16, 16, 16, 27.25, 8.0, 16, 16};
  const double nrm[12] = {1, 0, 0, 0, -1, 0, 0, 0, 1, -1, 0, 0};
  double t[12];
  uint8_t has[4];
  ffseg::SearchSettings st;
  CHECK(ffseg::search_binary(L.view, 4, x, nrm, st, t, has) == 4);
  for (int v = 0; v < 4; ++v) CHECK(has[v] == 1);
  CHECK(std::fabs(t[0] - 22.5) <= kTol);
  CHECK(std::fabs(t[4] - 9.5) <= kTol);
  CHECK(std::fabs(t[8] - 22.5) <= kTol);
  CHECK(std::fabs(t[9] - 9.5) <= kTol);
  CHECK(t[1] == 16);
  CHECK(t[10] == 16);
}
