#include "box_lattice.h"

namespace ffseg {

int64_t BoxLattice::count(int axis) const {
  const int64_t e = hi[axis] - lo[axis];
  if (e <= 0) return 0;
  // Multiples of the step from the low end, from the high end, less those
  // both ends reach (i - lo = 0 and e - 1 - (i - lo) = 0 mod step).
  const int64_t from_each = (e - 1) / step + 1;
  const int64_t r = (e - 1) % step;  // both: i - lo = 0 and = r (mod step)
  return r == 0 ? from_each : 2 * from_each;
}

BoxLattice BoxLattice::with_step(const int64_t lo[3], const int64_t hi[3], int64_t step) {
  BoxLattice b;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = lo[a];
    b.hi[a] = hi[a] > lo[a] ? hi[a] : lo[a];
  }
  b.step = step >= 1 ? step : 1;
  return b;
}

BoxLattice BoxLattice::fit(const int64_t lo[3], const int64_t hi[3], int64_t cap) {
  BoxLattice b = with_step(lo, hi, 1);
  if (cap < 1) cap = 1;
  int64_t longest = 1;
  for (int a = 0; a < 3; ++a) longest = b.hi[a] - b.lo[a] > longest ? b.hi[a] - b.lo[a] : longest;
  // The count falls (not strictly) with the step, and is 1 or 2 per axis
  // once the step reaches the longest extent.
  while (b.total() > cap && b.step < longest) ++b.step;
  return b;
}

}  // namespace ffseg
