#include "cubesphere_resample.h"

#include <cmath>

#include "triangulation.h"

namespace ffseg {

namespace {

// The source mesh's cells by face and index, one ring beyond each face
// included: cell (ia, ib) of the face with normal axis k and sign s (indices
// along the tangents t1 = k+1, t2 = k+2, as CubeSphere numbers them); an
// index of -1 or n is the cell across that cube edge, on the face of the
// tangent axis. Both out of range is a cube corner, where no cell is.
struct SourceGrid {
  const float* xyz;
  int32_t n;

  // The cell's integer cube coordinates (CubeSphere's), false at a corner.
  bool cell(int32_t k, int32_t s, int32_t ia, int32_t ib, int32_t P[3]) const {
    const int32_t t1 = (k + 1) % 3, t2 = (k + 2) % 3;
    const bool out1 = ia < 0 || ia >= n, out2 = ib < 0 || ib >= n;
    if ((out1 && out2) || ia < -1 || ia > n || ib < -1 || ib > n) return false;
    P[k] = s * n;
    P[t1] = 2 * ia - (n - 1);
    P[t2] = 2 * ib - (n - 1);
    // Across an edge the tangent coordinate that left the face becomes the
    // neighbouring face's normal one, and the cell lies one row in from the
    // edge along this face's normal.
    if (out1) {
      P[t1] = ia < 0 ? -n : n;
      P[k] = s * (n - 1);
    } else if (out2) {
      P[t2] = ib < 0 ? -n : n;
      P[k] = s * (n - 1);
    }
    return true;
  }
  uint32_t index(const int32_t P[3]) const {
    int32_t k = 0;
    while (k < 3 && (P[k] < 0 ? -P[k] : P[k]) != n) ++k;
    const uint32_t face = uint32_t(2 * k + (P[k] > 0 ? 1 : 0));
    const int32_t t1 = (k + 1) % 3, t2 = (k + 2) % 3;
    return face * uint32_t(n * n) + uint32_t((P[t1] + n - 1) / 2) * uint32_t(n) + uint32_t((P[t2] + n - 1) / 2);
  }
  // Its direction on the unit sphere, as CubeSphere::build places it.
  void unit(const int32_t P[3], double u[3]) const {
    int32_t k = 0;
    while ((P[k] < 0 ? -P[k] : P[k]) != n) ++k;
    double len = 0;
    for (int d = 0; d < 3; ++d) {
      u[d] = d == k ? double(P[d] > 0 ? 1 : -1) : std::tan(0.78539816339744830962 * double(P[d]) / double(n));
      len += u[d] * u[d];
    }
    len = std::sqrt(len);
    for (int d = 0; d < 3; ++d) u[d] /= len;
  }
};

double dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void cross(const double a[3], const double b[3], double c[3]) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

// Where the ray from the centre along u meets the plane of the source's
// unit triangle (A, B, C): its barycentric weights w, true when it lies in
// the triangle (to rounding).
bool ray_weights(const double u[3], const double A[3], const double B[3], const double C[3], double w[3]) {
  double e1[3], e2[3], nrm[3];
  for (int d = 0; d < 3; ++d) {
    e1[d] = B[d] - A[d];
    e2[d] = C[d] - A[d];
  }
  cross(e1, e2, nrm);
  const double un = dot(u, nrm);
  if (!(std::fabs(un) > 0)) return false;
  const double t = dot(A, nrm) / un;
  if (!(t > 0)) return false;
  double p[3], c1[3], c2[3];
  for (int d = 0; d < 3; ++d) p[d] = t * u[d] - A[d];
  // p = wB e1 + wC e2 in the plane: by the areas the cross products span.
  cross(p, e2, c1);
  cross(e1, p, c2);
  const double nn = dot(nrm, nrm);
  w[1] = dot(c1, nrm) / nn;
  w[2] = dot(c2, nrm) / nn;
  w[0] = 1 - w[1] - w[2];
  constexpr double kEps = -1e-9;
  return w[0] >= kEps && w[1] >= kEps && w[2] >= kEps;
}

}  // namespace

void resample_cubesphere(const CubeSphere& m, const float* src, uint32_t n_src, double* x) {
  if (n_src == m.n) {  // the same grid: a copy, bit for bit
    for (size_t q = 0; q < size_t(3) * m.nv; ++q) x[q] = double(src[q]);
    return;
  }
  const SourceGrid g{src, int32_t(n_src)};
  const double N = double(m.n), Ns = double(n_src);
  for (uint32_t v = 0; v < m.nv; ++v) {
    int32_t P[3];
    m.coords_of(v, P);
    int32_t k = 0;
    while ((P[k] < 0 ? -P[k] : P[k]) != int32_t(m.n)) ++k;
    const int32_t s = P[k] > 0 ? 1 : -1;
    // Both grids are equal-angle: the same angle coordinate P_t / n, in
    // source cell indices (centres at integers), gives the quad of source
    // cells around the vertex; the cube-sphere's warp near the cube's
    // corners can put it in a neighbouring quad, so the ring around is
    // searched too. Each quad is two triangles (a quad with a cube corner,
    // the corner's triangle of three cells), and the vertex's direction
    // picks the one it crosses: linear over it (a mesh that is the source's
    // surface, piecewise flat).
    const double a = (double(P[(k + 1) % 3]) / N * Ns + Ns - 1) / 2;
    const double b = (double(P[(k + 2) % 3]) / N * Ns + Ns - 1) / 2;
    const int32_t ia = int32_t(std::floor(a)), ib = int32_t(std::floor(b));
    const double* u = m.unit + 3 * size_t(v);
    double* out = x + 3 * size_t(v);
    bool done = false;
    for (int ring = 0; ring < 9 && !done; ++ring) {
      static const int kOrder[9][2] = {{0, 0}, {-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, 1}, {-1, 1}, {1, -1}};
      const int32_t qa = ia + kOrder[ring][0], qb = ib + kOrder[ring][1];
      // The quad's cells in cyclic order; a corner leaves three.
      const int32_t cells[4][2] = {{qa, qb}, {qa + 1, qb}, {qa + 1, qb + 1}, {qa, qb + 1}};
      int32_t cp[4][3];
      double cu[4][3];
      uint32_t idx[4];
      int count = 0;
      for (const auto& c : cells) {
        if (!g.cell(k, s, c[0], c[1], cp[count])) continue;
        g.unit(cp[count], cu[count]);
        idx[count] = g.index(cp[count]);
        ++count;
      }
      if (count < 3) continue;
      // The quad split as the engine splits it (triangulation.h: the
      // diagonal whose triangles bend least at the source's positions), so
      // that the resampled surface is the one the source mesh encloses.
      bool alt = false;
      if (count == 4) {
        double q[4][3];
        for (int c = 0; c < 4; ++c)
          for (int d = 0; d < 3; ++d) q[c][d] = double(src[3 * size_t(idx[c]) + d]);
        alt = detail::split_alt(detail::split_cos(q[0], q[1], q[2], q[3]), detail::split_cos(q[1], q[2], q[3], q[0]));
      }
      const int tris[2][3] = {{alt ? 1 : 0, alt ? 2 : 1, alt ? 3 : 2}, {alt ? 1 : 0, alt ? 3 : 2, alt ? 0 : 3}};
      for (int t = 0; t < (count == 4 ? 2 : 1) && !done; ++t) {
        double w[3];
        const int i0 = tris[t][0], i1 = tris[t][1], i2 = tris[t][2];
        if (!ray_weights(u, cu[i0], cu[i1], cu[i2], w)) continue;
        for (int d = 0; d < 3; ++d)
          out[d] = w[0] * double(src[3 * size_t(idx[i0]) + d]) + w[1] * double(src[3 * size_t(idx[i1]) + d]) +
                   w[2] * double(src[3 * size_t(idx[i2]) + d]);
        done = true;
      }
    }
    // Unreachable on a cube-sphere (the triangles tile the sphere); kept
    // finite all the same: the nearest cell.
    if (!done) {
      int32_t c[3];
      const int32_t ca = ia < 0 ? 0 : (ia >= int32_t(n_src) ? int32_t(n_src) - 1 : ia);
      const int32_t cb = ib < 0 ? 0 : (ib >= int32_t(n_src) ? int32_t(n_src) - 1 : ib);
      g.cell(k, s, ca, cb, c);
      for (int d = 0; d < 3; ++d) out[d] = double(src[3 * size_t(g.index(c)) + d]);
    }
  }
}

}  // namespace ffseg
