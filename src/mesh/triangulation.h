// Triangles of the cube-sphere: each quad split along the diagonal whose two
// triangles bend least (so a non-planar quad never becomes a sharp fold). The
// guard, the intersection tests, the rasteriser and mesh extraction all split
// quads the same way through these functions.
#pragma once
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "cubesphere.h"

namespace ffseg {

namespace detail {
inline double split_cos(const double* a, const double* b, const double* c, const double* d, double n1[3],
                        double n2[3]) {
  // cos of the angle between the normals n1 of triangle (a, b, c) and n2 of
  // (a, c, d), each (second - first) x (third - first).
  double u[3], w[3];
  for (int k = 0; k < 3; ++k) { u[k] = b[k] - a[k]; w[k] = c[k] - a[k]; }
  n1[0] = u[1] * w[2] - u[2] * w[1]; n1[1] = u[2] * w[0] - u[0] * w[2]; n1[2] = u[0] * w[1] - u[1] * w[0];
  for (int k = 0; k < 3; ++k) { u[k] = c[k] - a[k]; w[k] = d[k] - a[k]; }
  n2[0] = u[1] * w[2] - u[2] * w[1]; n2[1] = u[2] * w[0] - u[0] * w[2]; n2[2] = u[0] * w[1] - u[1] * w[0];
  const double l = (n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]) * (n2[0] * n2[0] + n2[1] * n2[1] + n2[2] * n2[2]);
  return l > 0 ? (n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]) / __builtin_sqrt(l) : -1.0;
}
inline double split_cos(const double* a, const double* b, const double* c, const double* d) {
  double n1[3], n2[3];
  return split_cos(a, b, c, d, n1, n2);
}
// The two splits of the quad p0 p1 p2 p3 at once: c02 = split_cos(p0, p1,
// p2, p3, a0, a1) and c13 = split_cos(p1, p2, p3, p0, b0, b1), the same
// values bit for bit. The square roots and divisions, the slow part of the
// split decision that every test of moved positions makes per quad, go side
// by side in one SSE2 instruction each where there is SSE2 (correctly
// rounded, lane by lane, as the scalar ones).
inline void split_cos_both(const double* p0, const double* p1, const double* p2, const double* p3, double* c02,
                           double* c13, double a0[3], double a1[3], double b0[3], double b1[3]) {
  auto normal = [](const double* a, const double* b, const double* c, double n[3]) {
    double u[3], w[3];
    for (int k = 0; k < 3; ++k) { u[k] = b[k] - a[k]; w[k] = c[k] - a[k]; }
    n[0] = u[1] * w[2] - u[2] * w[1]; n[1] = u[2] * w[0] - u[0] * w[2]; n[2] = u[0] * w[1] - u[1] * w[0];
  };
  normal(p0, p1, p2, a0);
  normal(p0, p2, p3, a1);
  normal(p1, p2, p3, b0);
  normal(p1, p3, p0, b1);
  auto sq = [](const double* n) { return n[0] * n[0] + n[1] * n[1] + n[2] * n[2]; };
  const double la = sq(a0) * sq(a1), lb = sq(b0) * sq(b1);
  const double da = a0[0] * a1[0] + a0[1] * a1[1] + a0[2] * a1[2];
  const double db = b0[0] * b1[0] + b0[1] * b1[1] + b0[2] * b1[2];
#if defined(__SSE2__)
  const __m128d q = _mm_div_pd(_mm_set_pd(db, da), _mm_sqrt_pd(_mm_set_pd(lb, la)));
  *c02 = la > 0 ? _mm_cvtsd_f64(q) : -1.0;
  *c13 = lb > 0 ? _mm_cvtsd_f64(_mm_unpackhi_pd(q, q)) : -1.0;
#else
  *c02 = la > 0 ? da / __builtin_sqrt(la) : -1.0;
  *c13 = lb > 0 ? db / __builtin_sqrt(lb) : -1.0;
#endif
}
// Whether face_triangles() splits the quad p0 p1 p2 p3 along the 1-3
// diagonal, given the two splits' cosines.
inline bool split_alt(double cos02, double cos13) { return cos13 > cos02 + 1e-12; }
}  // namespace detail

// Writes the triangles of face f (3 or 6 indices); returns how many triangles.
// A quad is split along the diagonal whose two triangles bend least at the
// positions x (3 per vertex; nullptr: always the 0-2 diagonal), so a
// non-planar quad never becomes a sharp fold.
// face_triangles()' output for face f split along the 0-2 diagonal (alt
// false) or the 1-3 diagonal (alt true).
inline int face_split(const CubeSphere& m, uint32_t f, bool alt, uint32_t out[6]) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  if (q[3] == kNone) {
    out[0] = q[0]; out[1] = q[1]; out[2] = q[2];
    return 1;
  }
  if (!alt) {
    out[0] = q[0]; out[1] = q[1]; out[2] = q[2];
    out[3] = q[0]; out[4] = q[2]; out[5] = q[3];
  } else {
    out[0] = q[1]; out[1] = q[2]; out[2] = q[3];
    out[3] = q[1]; out[4] = q[3]; out[5] = q[0];
  }
  return 2;
}

inline int face_triangles(const CubeSphere& m, uint32_t f, uint32_t out[6], const double* x = nullptr) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  bool alt = false;
  if (x && q[3] != kNone) {
    const double *p0 = x + 3 * size_t(q[0]), *p1 = x + 3 * size_t(q[1]), *p2 = x + 3 * size_t(q[2]),
                 *p3 = x + 3 * size_t(q[3]);
    double c02, c13, n[4][3];
    detail::split_cos_both(p0, p1, p2, p3, &c02, &c13, n[0], n[1], n[2], n[3]);
    alt = detail::split_alt(c02, c13);
  }
  return face_split(m, f, alt, out);
}

// All triangles, 3 indices each, outward (counter-clockwise seen from outside),
// quads split as face_triangles does for positions x (may be nullptr).
void triangulate(const CubeSphere& m, const double* x, uint32_t* tris);

}  // namespace ffseg
