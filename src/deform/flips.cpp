#include "flips.h"

#include <cmath>

namespace ffseg {

namespace {

bool edge_flips(const double* x, const double* t, uint32_t i, uint32_t j, double tau) {
  double a[3], b[3];
  for (int d = 0; d < 3; ++d) {
    a[d] = x[3 * size_t(i) + d] - x[3 * size_t(j) + d];
    b[d] = t[3 * size_t(i) + d] - t[3 * size_t(j) + d];
  }
  const double la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  const double lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  if (!(la > 0) || !(lb > 0)) return true;  // collapsing onto one point is a flip
  return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb) <= tau;
}

}  // namespace

uint32_t detect_flips(const CubeSphere& m, const double* x, const double* target, const uint8_t* has,
                      double tau, uint8_t* flipping) {
  for (uint32_t v = 0; v < m.nv; ++v) flipping[v] = 0;
  for (uint32_t l = 0; l < m.nloops; ++l) {
    const uint32_t* L = m.loops + size_t(l) * m.loop_len;
    uint32_t first = kNone, prev = kNone;
    for (uint32_t p = 0; p < m.loop_len; ++p) {
      const uint32_t v = L[p];
      if (!has[v]) continue;
      if (prev != kNone && edge_flips(x, target, prev, v, tau)) flipping[prev] = flipping[v] = 1;
      if (first == kNone) first = v;
      prev = v;
    }
    if (first != kNone && prev != first && edge_flips(x, target, prev, first, tau))
      flipping[prev] = flipping[first] = 1;
  }
  uint32_t count = 0;
  for (uint32_t v = 0; v < m.nv; ++v) count += flipping[v];
  return count;
}

uint32_t avoid_flips(const CubeSphere& m, const uint8_t* flipping, uint8_t* has, uint32_t* seq) {
  uint32_t removed = 0;
  for (uint32_t l = 0; l < m.nloops; ++l) {
    const uint32_t* L = m.loops + size_t(l) * m.loop_len;
    // The loop's non-solitary vertices, in order, starting right after a
    // non-flipping one so that no run wraps around the end.
    uint32_t count = 0, start = kNone;
    for (uint32_t p = 0; p < m.loop_len; ++p) {
      const uint32_t v = L[p];
      if (has[v] && !flipping[v]) start = p;
    }
    const uint32_t from = start == kNone ? 0 : start + 1;
    for (uint32_t q = 0; q < m.loop_len; ++q) {
      const uint32_t v = L[(from + q) % m.loop_len];
      if (has[v]) seq[count++] = v;
    }
    uint32_t i = 0;
    while (i < count) {
      if (!flipping[seq[i]]) { ++i; continue; }
      uint32_t j = i;
      while (j < count && flipping[seq[j]]) ++j;
      const uint32_t keep = i + (j - i) / 2;
      for (uint32_t r = i; r < j; ++r)
        if (r != keep && has[seq[r]]) { has[seq[r]] = 0; ++removed; }
      i = j;
    }
  }
  return removed;
}

}  // namespace ffseg
