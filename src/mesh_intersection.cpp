#include "mesh_intersection.h"

#include <cmath>

#include "rasterize.h"

namespace ffseg {

void TriangleScratch::carve(Arena& a, const CubeSphere& m) {
  const uint32_t nt = m.triangle_count();
  tris = a.alloc<uint32_t>(size_t(3) * nt);
  centroid = a.alloc<double>(size_t(3) * nt);
  radius = a.alloc<double>(nt);
  grid.carve(a, nt);
}

namespace {

// Six times the signed volume of (a, b, c, d).
double orient(const double* a, const double* b, const double* c, const double* d) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}

// The open segment pq passes through the interior of triangle t0 t1 t2.
bool segment_crosses(const double* p, const double* q, const double* t0, const double* t1, const double* t2) {
  const double dp = orient(t0, t1, t2, p), dq = orient(t0, t1, t2, q);
  if (!((dp > 0 && dq < 0) || (dp < 0 && dq > 0))) return false;
  const double e0 = orient(p, q, t0, t1), e1 = orient(p, q, t1, t2), e2 = orient(p, q, t2, t0);
  return (e0 > 0 && e1 > 0 && e2 > 0) || (e0 < 0 && e1 < 0 && e2 < 0);
}

bool triangles_cross(const CubeSphere& m, const double* x, const uint32_t* a, const uint32_t* b) {
  (void)m;
  int shared = 0, sa = -1, sb = -1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) {
        ++shared;
        sa = i;
        sb = j;
      }
  if (shared >= 2) return false;  // neighbours across an edge: the fold test's business
  auto P = [&](uint32_t v) { return x + 3 * size_t(v); };
  const double *A[3] = {P(a[0]), P(a[1]), P(a[2])}, *B[3] = {P(b[0]), P(b[1]), P(b[2])};
  if (shared == 1) {
    // Only the edges opposite the shared vertex can cross the other triangle
    // away from that vertex.
    return segment_crosses(A[(sa + 1) % 3], A[(sa + 2) % 3], B[0], B[1], B[2]) ||
           segment_crosses(B[(sb + 1) % 3], B[(sb + 2) % 3], A[0], A[1], A[2]);
  }
  for (int i = 0; i < 3; ++i) {
    if (segment_crosses(A[i], A[(i + 1) % 3], B[0], B[1], B[2])) return true;
    if (segment_crosses(B[i], B[(i + 1) % 3], A[0], A[1], A[2])) return true;
  }
  return false;
}

}  // namespace

uint32_t mark_intersections(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark) {
  const uint32_t nt = m.triangle_count();
  triangulate(m, x, s.tris);
  double rmax = 0, rsum = 0;
  for (uint32_t t = 0; t < nt; ++t) {
    const uint32_t* id = s.tris + 3 * size_t(t);
    double* c = s.centroid + 3 * size_t(t);
    for (int a = 0; a < 3; ++a)
      c[a] = (x[3 * size_t(id[0]) + a] + x[3 * size_t(id[1]) + a] + x[3 * size_t(id[2]) + a]) / 3.0;
    double r2 = 0;
    for (int k = 0; k < 3; ++k) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += (x[3 * size_t(id[k]) + a] - c[a]) * (x[3 * size_t(id[k]) + a] - c[a]);
      r2 = std::fmax(r2, d2);
    }
    s.radius[t] = std::sqrt(r2);
    rmax = std::fmax(rmax, s.radius[t]);
    rsum += s.radius[t];
  }
  if (!(rmax > 0) || !std::isfinite(rmax)) return 0;
  s.grid.build(s.centroid, nt, std::fmax(2 * rsum / nt, 1e-9 * rmax));
  uint32_t pairs = 0;
  for (uint32_t t = 0; t < nt; ++t) {
    const uint32_t* a = s.tris + 3 * size_t(t);
    bool stop = false;
    s.grid.for_each_in_ball(s.centroid + 3 * size_t(t), s.radius[t] + rmax, [&](uint32_t u) {
      if (u <= t || stop) return;
      const double* cu = s.centroid + 3 * size_t(u);
      const double* ct = s.centroid + 3 * size_t(t);
      const double dc2 = (cu[0] - ct[0]) * (cu[0] - ct[0]) + (cu[1] - ct[1]) * (cu[1] - ct[1]) + (cu[2] - ct[2]) * (cu[2] - ct[2]);
      const double reach = s.radius[t] + s.radius[u];
      if (dc2 > reach * reach) return;
      const uint32_t* b = s.tris + 3 * size_t(u);
      if (!triangles_cross(m, x, a, b)) return;
      ++pairs;
      if (!mark) {
        stop = true;
        return;
      }
      for (int k = 0; k < 3; ++k) mark[a[k]] = mark[b[k]] = 1;
    });
    if (stop) break;
  }
  return pairs;
}

}  // namespace ffseg
