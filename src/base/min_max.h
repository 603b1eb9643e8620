// std::fmin / std::fmax without a libm call. The generic x86-64 build has no
// instruction with their NaN rule, so each std::fmin / fmax is a call; in a
// loop over every vertex or triangle that is most of the loop's work. These
// give glibc's x86-64 values bit for bit: an ordered pair as minsd / maxsd
// order it (a tie gives y, so -0 and +0 give y), a quiet NaN operand the
// other operand; two NaNs or a signalling one give a NaN, as there, though
// its payload may differ (tests/base/test_min_max.cpp: every pair of zeros,
// infinities, subnormals, quiet and signalling NaNs of either sign).
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

namespace ffseg {

namespace min_max_detail {

inline bool signalling_nan(double v) {
  uint64_t u;
  std::memcpy(&u, &v, sizeof u);
  return v != v && !(u & (uint64_t(1) << 51));
}

// fmin / fmax of an unordered pair (at least one NaN).
inline double unordered(double x, double y) {
  if ((x != x && y != y) || signalling_nan(x) || signalling_nan(y)) return x + y;
  return x != x ? y : x;
}

}  // namespace min_max_detail

// The NaN test first (one unordered comparison, predictably false), then
// the conditional that compiles to minsd / maxsd: no branch on which operand
// is smaller, which is data (a triangle's corners) in the rasteriser.
inline double fmin_inline(double x, double y) {
  if (__builtin_expect(std::isunordered(x, y), 0)) return min_max_detail::unordered(x, y);
  return x < y ? x : y;
}

inline double fmax_inline(double x, double y) {
  if (__builtin_expect(std::isunordered(x, y), 0)) return min_max_detail::unordered(x, y);
  return x > y ? x : y;
}

}  // namespace ffseg
