// fmin_inline / fmax_inline (src/base/min_max.h) against std::fmin / fmax,
// bit for bit, on every pair of a set of special values (a NaN's payload
// aside: where the library gives a NaN, a NaN).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "min_max.h"

namespace {

// The bits of v, every NaN's the same (the payload is not promised).
uint64_t bits(double v) {
  if (v != v) return 0x7ff8000000000000u;
  uint64_t u;
  std::memcpy(&u, &v, sizeof u);
  return u;
}

}  // namespace

TEST_CASE("min max: the inline fmin / fmax give std::fmin / fmax's bits") {
  using L = std::numeric_limits<double>;
  // volatile: the library's functions are called, not folded by the compiler.
  volatile double vals[] = {0.0,         -0.0,         1.0,          -1.0,          2.5,
                            L::infinity(), -L::infinity(), L::quiet_NaN(), -L::quiet_NaN(), L::signaling_NaN(),
                            L::denorm_min(), -L::denorm_min(), L::max(),     -L::max(),     1.0 + L::epsilon()};
  double (*lib_min)(double, double) = std::fmin;
  double (*lib_max)(double, double) = std::fmax;
  for (double x : vals)
    for (double y : vals) {
      // Of two zeros C leaves the sign to the library; glibc on x86-64 gives
      // y (minsd / maxsd), which min_max.h copies. Elsewhere a zero.
      const bool zeros = x == 0 && y == 0;
#if defined(__x86_64__)
      const bool exact = true;
#else
      const bool exact = !zeros;
#endif
      if (exact) {
        CHECK(bits(ffseg::fmin_inline(x, y)) == bits(lib_min(x, y)));
        CHECK(bits(ffseg::fmax_inline(x, y)) == bits(lib_max(x, y)));
      } else {
        CHECK(ffseg::fmin_inline(x, y) == 0.0);
        CHECK(ffseg::fmax_inline(x, y) == 0.0);
      }
    }
}
