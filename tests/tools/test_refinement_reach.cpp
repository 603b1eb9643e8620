// The reach of a finer run from a first-run mesh (tools/cli/refinement_reach.h):
// the volume it encloses plus its area times its mean quad side.
#include <doctest/doctest.h>

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "cli/refinement_reach.h"

using namespace ffseg_cli;

namespace {

// A box of a x b x c mm made of its six faces, each one quad split into two
// triangles, counter-clockwise seen from outside.
void box(double a, double b, double c, std::vector<float>* xyz, std::vector<uint32_t>* tris) {
  for (int i = 0; i < 8; ++i) {
    xyz->push_back(float(i & 1 ? a : 0));
    xyz->push_back(float(i & 2 ? b : 0));
    xyz->push_back(float(i & 4 ? c : 0));
  }
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads)
    for (uint32_t v : {q[0], q[1], q[2], q[0], q[2], q[3]}) tris->push_back(v);
}

}  // namespace

TEST_CASE("refinement reach: a box's volume, its quad sides, and the shell one side thick") {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  box(2, 3, 4, &xyz, &tris);
  CHECK(enclosed_volume_mm3(xyz, tris) == doctest::Approx(24.0));
  // Each face's triangles count its two sides twice: (2 + 3) x 4 on the z
  // faces, (2 + 4) x 4 on the y faces, (3 + 4) x 4 on the x faces, over 24.
  const double side = ((2 + 3) * 4 + (2 + 4) * 4 + (3 + 4) * 4) / 24.0;
  CHECK(mean_quad_side_mm(xyz, tris) == doctest::Approx(side));
  CHECK(refinement_reach_mm3(xyz, tris) == doctest::Approx(24.0 + 52.0 * side));
  // Turned inside out, the volume is negative: the orientation matters.
  for (size_t t = 0; t < tris.size(); t += 3) std::swap(tris[t + 1], tris[t + 2]);
  CHECK(enclosed_volume_mm3(xyz, tris) == doctest::Approx(-24.0));
  CHECK(mean_quad_side_mm(xyz, {}) == 0.0);
}
