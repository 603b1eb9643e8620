// The exact-sign primitives of the mesh crossing tests: the orientation of
// four points, an open segment through a triangle's interior, two triangles
// with no vertex in common crossing, a triangle's bounding box. The
// self-intersection test (mesh_intersection) and the contact test between
// meshes (mesh_contact) decide every pair with these, so one mesh and two
// meshes are kept apart by the same rule. Internal to the mesh layer.
#pragma once
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace ffseg {
namespace detail {

// Six times the signed volume of (a, b, c, d). Inlined into the pair tests,
// the hot loops of the guard (generic x86-64: no contraction, same rounding).
inline __attribute__((always_inline)) double orient(const double* a, const double* b, const double* c,
                                                    const double* d) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}

// The line through p and q meets the interior of triangle t0 t1 t2 (for a
// segment whose ends lie on both sides of the triangle's plane: it crosses).
inline __attribute__((always_inline)) bool segment_through(const double* p, const double* q, const double* t0,
                                                           const double* t1, const double* t2) {
  const double e0 = orient(p, q, t0, t1), e1 = orient(p, q, t1, t2), e2 = orient(p, q, t2, t0);
  return (e0 > 0 && e1 > 0 && e2 > 0) || (e0 < 0 && e1 < 0 && e2 < 0);
}

// The open segment pq passes through the interior of triangle t0 t1 t2.
inline __attribute__((always_inline)) bool segment_crosses(const double* p, const double* q, const double* t0,
                                                           const double* t1, const double* t2) {
  const double dp = orient(t0, t1, t2, p), dq = orient(t0, t1, t2, q);
  if (!((dp > 0 && dq < 0) || (dp < 0 && dq > 0))) return false;
  return segment_through(p, q, t0, t1, t2);
}

// Triangles A and B (three corners each) with no vertex in common cross: an
// edge of one passes through the other's interior. Coplanar touching is not
// a crossing. segment_crosses() of each edge, with each corner's side of the
// other triangle's plane computed once (an edge's two ends read the same
// orient() values), so the same answer; most pairs tested lie on one side
// of a plane and stop at these six.
// Where there is SSE2 the six go in pairs, A's corner k against B's plane
// and B's corner k against A's side by side in one instruction each:
// orient()'s operations in its order, lane by lane, so the same values.
inline bool disjoint_triangles_cross(const double* const A[3], const double* const B[3]) {
#if defined(__SSE2__)
  // Which edges straddle the other's plane, as sign masks: bit i for A's
  // edge i (corners i, i + 1) against B's plane, bit 4 + i for B's edge i
  // against A's; one branch for the pairs where none does (most of them).
  // The answer is whether some straddling edge passes through the other
  // triangle, whichever is asked first (segment_through() reads nothing
  // else), so the straddling edges are then asked in the loop's order.
  uint32_t edges = 0;
  {
    // Lane 0: triangle B and A's corners; lane 1: triangle A and B's.
    auto pair = [](const double* p, const double* q, int c) { return _mm_set_pd(q[c], p[c]); };
    __m128d u[3], v[3];
    for (int c = 0; c < 3; ++c) {
      const __m128d o = pair(B[0], A[0], c);
      u[c] = _mm_sub_pd(pair(B[1], A[1], c), o);
      v[c] = _mm_sub_pd(pair(B[2], A[2], c), o);
    }
    __m128d pos[3], neg[3];
    for (int k = 0; k < 3; ++k) {
      __m128d w[3];
      for (int c = 0; c < 3; ++c) w[c] = _mm_sub_pd(pair(A[k], B[k], c), pair(B[0], A[0], c));
      const __m128d t0 = _mm_sub_pd(_mm_mul_pd(v[1], w[2]), _mm_mul_pd(v[2], w[1]));
      const __m128d t1 = _mm_sub_pd(_mm_mul_pd(v[0], w[2]), _mm_mul_pd(v[2], w[0]));
      const __m128d t2 = _mm_sub_pd(_mm_mul_pd(v[0], w[1]), _mm_mul_pd(v[1], w[0]));
      const __m128d r =
          _mm_add_pd(_mm_sub_pd(_mm_mul_pd(u[0], t0), _mm_mul_pd(u[1], t1)), _mm_mul_pd(u[2], t2));
      pos[k] = _mm_cmpgt_pd(r, _mm_setzero_pd());
      neg[k] = _mm_cmplt_pd(r, _mm_setzero_pd());
    }
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3;
      const int m = _mm_movemask_pd(_mm_or_pd(_mm_and_pd(pos[i], neg[j]), _mm_and_pd(neg[i], pos[j])));
      edges |= uint32_t(m & 1) << i | uint32_t(m >> 1) << (4 + i);
    }
  }
  if (edges == 0) return false;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    if ((edges >> i & 1) && segment_through(A[i], A[j], B[0], B[1], B[2])) return true;
    if ((edges >> (4 + i) & 1) && segment_through(B[i], B[j], A[0], A[1], A[2])) return true;
  }
  return false;
#else
  const double da[3] = {orient(B[0], B[1], B[2], A[0]), orient(B[0], B[1], B[2], A[1]), orient(B[0], B[1], B[2], A[2])};
  const double db[3] = {orient(A[0], A[1], A[2], B[0]), orient(A[0], A[1], A[2], B[1]), orient(A[0], A[1], A[2], B[2])};
  auto straddle = [](double p, double q) { return (p > 0 && q < 0) || (p < 0 && q > 0); };
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    if (straddle(da[i], da[j]) && segment_through(A[i], A[j], B[0], B[1], B[2])) return true;
    if (straddle(db[i], db[j]) && segment_through(B[i], B[j], A[0], A[1], A[2])) return true;
  }
  return false;
#endif
}

// The bounding box of triangle p0 p1 p2, widened by eps (3 each in lo, hi).
// Finite positions: these comparisons give fmin/fmax's values (the sign of a
// zero aside, which no test reads), without a libm call.
inline void triangle_box(const double* p0, const double* p1, const double* p2, double eps, double* lo, double* hi) {
  for (int a = 0; a < 3; ++a) {
    const double l01 = p1[a] < p0[a] ? p1[a] : p0[a], h01 = p1[a] > p0[a] ? p1[a] : p0[a];
    lo[a] = (p2[a] < l01 ? p2[a] : l01) - eps;
    hi[a] = (p2[a] > h01 ? p2[a] : h01) + eps;
  }
}

// Closed boxes [la, ha] and [lb, hb] (3 each) overlap.
inline bool boxes_overlap(const double* la, const double* ha, const double* lb, const double* hb) {
  return !(lb[0] > ha[0] || la[0] > hb[0] || lb[1] > ha[1] || la[1] > hb[1] || lb[2] > ha[2] || la[2] > hb[2]);
}

}  // namespace detail
}  // namespace ffseg
