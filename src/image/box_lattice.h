// A subsample of an index box that does not depend on how the volume is
// stored: the same voxels of the anatomy are chosen when the grid is flipped
// along any axis or its axes are permuted (issue 19: a Colin27 caudate stored
// with its first axis reversed was another caudate because the statistics
// were a stride over the box in scan order).
//
// Along each axis of the box [lo, hi) the chosen indices are those at a
// multiple of the step from either end, i - lo = 0 (mod step) or
// hi - 1 - i = 0 (mod step): the set and its mirror image are one. The step is
// the same along every axis, the least with at most `cap` chosen voxels, so a
// permutation of the axes chooses the permuted voxels. Step 1 is every voxel.
#pragma once
#include <cstdint>

namespace ffseg {

struct BoxLattice {
  int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  int64_t step = 1;

  // The least step giving at most cap voxels of [lo, hi) (cap >= 1; a box
  // that meets no voxel chooses none).
  static BoxLattice fit(const int64_t lo[3], const int64_t hi[3], int64_t cap);
  // With a given step (>= 1).
  static BoxLattice with_step(const int64_t lo[3], const int64_t hi[3], int64_t step);

  bool chosen(int axis, int64_t i) const {
    return (i - lo[axis]) % step == 0 || (hi[axis] - 1 - i) % step == 0;
  }
  // Chosen indices along one axis, and voxels in all.
  int64_t count(int axis) const;
  int64_t total() const { return count(0) * count(1) * count(2); }

  // f(i, j, k) at every chosen voxel, k slowest.
  template <class F>
  void for_each(F&& f) const {
    for (int64_t k = lo[2]; k < hi[2]; ++k) {
      if (!chosen(2, k)) continue;
      for (int64_t j = lo[1]; j < hi[1]; ++j) {
        if (!chosen(1, j)) continue;
        for (int64_t i = lo[0]; i < hi[0]; ++i)
          if (chosen(0, i)) f(i, j, k);
      }
    }
  }
};

}  // namespace ffseg
