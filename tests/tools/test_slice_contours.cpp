// Tests for tools/geometry/slice_contours: a closed mesh cut by planes gives
// closed polygons exactly on the plane (one per piece, holes separate), and
// an open mesh is refused.
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "nifti.h"
#include "slice_contours.h"

using namespace ffseg_tools;

namespace {

// A torus around the z axis (radii R, r), nu x nv quads split in triangles.
void torus(double R, double r, int nu, int nv, double cx, std::vector<float>* xyz, std::vector<uint32_t>* tris) {
  for (int u = 0; u < nu; ++u)
    for (int v = 0; v < nv; ++v) {
      const double a = 2 * M_PI * u / nu, b = 2 * M_PI * (v + 0.5) / nv;
      xyz->push_back(float(cx + (R + r * std::cos(b)) * std::cos(a)));
      xyz->push_back(float((R + r * std::cos(b)) * std::sin(a)));
      xyz->push_back(float(r * std::sin(b)));
    }
  const uint32_t base = 0;
  for (int u = 0; u < nu; ++u)
    for (int v = 0; v < nv; ++v) {
      const uint32_t p = base + uint32_t(u * nv + v), q = base + uint32_t(((u + 1) % nu) * nv + v);
      const uint32_t p1 = base + uint32_t(u * nv + (v + 1) % nv), q1 = base + uint32_t(((u + 1) % nu) * nv + (v + 1) % nv);
      tris->insert(tris->end(), {p, q, q1, p, q1, p1});
    }
}

double signed_area_xy(const Polygon& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto& s = p[i];
    const auto& t = p[(i + 1) % p.size()];
    a += s[0] * t[1] - t[0] * s[1];
  }
  return a / 2;
}

// The torus (radii 10, 3; nu x nv) cut by the plane n . x = d.
std::vector<Polygon> cut_torus(int nu, int nv, const double n[3], double d) {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  torus(10, 3, nu, nv, 0, &xyz, &tris);
  std::vector<Polygon> polys;
  std::string err;
  REQUIRE_MESSAGE(plane_contours(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3, n, d, &polys, &err), err);
  return polys;
}

}  // namespace

TEST_CASE("slice contours: a torus cut across its hole gives an outer and an inner polygon on the plane") {
  const double n[3] = {0, 0, 1};
  const std::vector<Polygon> polys = cut_torus(96, 48, n, 0.7);
  REQUIRE(polys.size() == 2);
  double areas[2];
  for (int q = 0; q < 2; ++q) {
    for (const auto& p : polys[size_t(q)]) CHECK(std::fabs(p[2] - 0.7) < 1e-9);
    areas[q] = std::fabs(signed_area_xy(polys[size_t(q)]));
  }
  // The ring's two circles at z = 0.7: radii 10 +- sqrt(9 - 0.49).
  const double h = std::sqrt(9 - 0.49), outer = M_PI * (10 + h) * (10 + h), inner = M_PI * (10 - h) * (10 - h);
  const double big = std::max(areas[0], areas[1]), small = std::min(areas[0], areas[1]);
  CHECK(big == doctest::Approx(outer).epsilon(0.01));
  CHECK(small == doctest::Approx(inner).epsilon(0.02));
}

TEST_CASE("slice contours: a plane through the torus's side gives two separate pieces; above it none") {
  const double n[3] = {1, 0, 0};
  const std::vector<Polygon> polys = cut_torus(64, 32, n, 0.0);
  CHECK(polys.size() == 2);
  for (const Polygon& p : polys)
    for (const auto& q : p) CHECK(std::fabs(q[0]) < 1e-9);
  const double up[3] = {0, 0, 1};
  CHECK(cut_torus(64, 32, up, 3.5).empty());
}

TEST_CASE("slice contours: the planes of a grid's slices, and an open mesh refused") {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  torus(10, 3, 64, 32, 0, &xyz, &tris);
  NiftiImage grid;
  grid.dims[0] = grid.dims[1] = 40;
  grid.dims[2] = 10;
  const double m[16] = {1, 0, 0, -20, 0, 1, 0, -20, 0, 0, 0.75, -4, 0, 0, 0, 1};
  for (int q = 0; q < 16; ++q) grid.index_to_world[q] = m[q];
  std::vector<SliceContour> cut;
  std::string err;
  REQUIRE(grid_slice_contours(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3, grid, &cut, &err));
  // Slices at z = -4 + 0.75 k inside |z| < 3: k = 2..9, two polygons each.
  CHECK(cut.size() == 16);
  for (const SliceContour& c : cut) {
    CHECK(c.slice >= 2);
    for (const auto& p : c.points) CHECK(std::fabs(p[2] - (-4 + 0.75 * c.slice)) < 1e-9);
  }
  tris.resize(tris.size() - 3);  // one triangle missing: a hole in the surface
  CHECK_FALSE(grid_slice_contours(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3, grid, &cut, &err));
  CHECK(err.find("not closed") != std::string::npos);
}
