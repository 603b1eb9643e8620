// The statistics' subsample: a flip or a permutation of the box's axes
// chooses the mirrored or permuted voxels (box_lattice.h).
#include <doctest/doctest.h>

#include <cstddef>
#include <set>
#include <tuple>

#include "box_lattice.h"

using ffseg::BoxLattice;

namespace {

std::set<std::tuple<int64_t, int64_t, int64_t>> chosen(const BoxLattice& b) {
  std::set<std::tuple<int64_t, int64_t, int64_t>> s;
  b.for_each([&](int64_t i, int64_t j, int64_t k) { s.insert({i, j, k}); });
  return s;
}

}  // namespace

TEST_CASE("box lattice: the chosen voxels are mirrored by a flip and permuted by a permutation, within the cap") {
  const int64_t boxes[][6] = {{3, 5, -2, 40, 31, 9}, {0, 0, 0, 17, 17, 17}, {10, 20, 30, 11, 57, 34},
                              {-4, 0, 2, 96, 61, 80}};
  for (const auto& bx : boxes) {
    const int64_t lo[3] = {bx[0], bx[1], bx[2]}, hi[3] = {bx[3], bx[4], bx[5]};
    const int64_t voxels = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
    for (const int64_t cap : {int64_t(1) << 40, int64_t(4681), int64_t(500), int64_t(9)}) {
      CAPTURE(cap);
      const BoxLattice b = BoxLattice::fit(lo, hi, cap);
      const auto s = chosen(b);
      CHECK(int64_t(s.size()) == b.total());
      if (cap >= voxels) CHECK(b.total() == voxels);  // every voxel when they fit
      if (b.step > 1) {
        CHECK(b.total() <= cap);
        // The least such step.
        CHECK(BoxLattice::with_step(lo, hi, b.step - 1).total() > cap);
      }
      for (const auto& v : s) {
        const int64_t p[3] = {std::get<0>(v), std::get<1>(v), std::get<2>(v)};
        for (int a = 0; a < 3; ++a) {
          int64_t q[3] = {p[0], p[1], p[2]};
          q[a] = lo[a] + hi[a] - 1 - p[a];  // the flip along axis a
          CHECK(s.count({q[0], q[1], q[2]}) == 1);
        }
      }
      // The box with axes (j, k, i): the same step, the permuted voxels.
      const int64_t plo[3] = {lo[1], lo[2], lo[0]}, phi[3] = {hi[1], hi[2], hi[0]};
      const BoxLattice pb = BoxLattice::fit(plo, phi, cap);
      CHECK(pb.step == b.step);
      size_t same = 0;
      for (const auto& v : chosen(pb)) same += s.count({std::get<2>(v), std::get<0>(v), std::get<1>(v)});
      CHECK(same == s.size());
    }
  }
}
