// Cube-sphere construction. Integer cube coordinates scaled by n: a cell centre
// on the face with normal axis k and sign s has P_k = s n and odd tangent
// coordinates in [-(n-1), n-1]; grid corners have coordinates of n's parity.
#include "cubesphere.h"

#include <cmath>
#include <cstdlib>

#include "tangent_frame.h"

namespace ffseg {
namespace {

inline int32_t iabs(int32_t x) { return x < 0 ? -x : x; }

// Face f: axis k = f / 2, sign -1 for even f, +1 for odd f.
inline uint32_t face_of(int32_t k, int32_t s) { return uint32_t(2 * k + (s > 0 ? 1 : 0)); }

}  // namespace

void CubeSphere::carve(Arena& a, uint32_t n_) {
  n = n_;
  nv = 6 * n * n;
  nfaces = 6 * n * n + 2;
  nloops = 3 * n;
  loop_len = 4 * n;
  nbr = a.alloc<uint32_t>(size_t(4) * nv);
  loops = a.alloc<uint32_t>(size_t(nloops) * loop_len);
  vloop = a.alloc<uint32_t>(size_t(2) * nv);
  vpos = a.alloc<uint32_t>(size_t(2) * nv);
  faces = a.alloc<uint32_t>(size_t(4) * nfaces);
  fadj = a.alloc<uint32_t>(size_t(4) * nfaces);
  vfaces = a.alloc<uint32_t>(size_t(4) * nv);
  unit = a.alloc<double>(size_t(3) * nv);
}

uint32_t CubeSphere::index_of(const int32_t P[3]) const {
  const int32_t N = int32_t(n);
  int32_t k = 0;
  while (k < 3 && iabs(P[k]) != N) ++k;
  const int32_t s = P[k] > 0 ? 1 : -1;
  const int32_t t1 = (k + 1) % 3, t2 = (k + 2) % 3;
  const uint32_t a = uint32_t((P[t1] + N - 1) / 2), b = uint32_t((P[t2] + N - 1) / 2);
  return face_of(k, s) * n * n + a * n + b;
}

void CubeSphere::coords_of(uint32_t v, int32_t P[3]) const {
  const int32_t N = int32_t(n);
  const uint32_t f = v / (n * n), r = v % (n * n);
  const int32_t k = int32_t(f / 2), s = (f % 2) ? 1 : -1;
  const int32_t t1 = (k + 1) % 3, t2 = (k + 2) % 3;
  P[k] = s * N;
  P[t1] = -(N - 1) + 2 * int32_t(r / n);
  P[t2] = -(N - 1) + 2 * int32_t(r % n);
}

void CubeSphere::build() {
  const int32_t N = int32_t(n);
  const double q = 0.78539816339744830962;  // pi / 4

  // Positions and neighbours.
  for (uint32_t v = 0; v < nv; ++v) {
    int32_t P[3];
    coords_of(v, P);
    int32_t k = 0;
    while (iabs(P[k]) != N) ++k;
    double c[3];
    for (int d = 0; d < 3; ++d)
      c[d] = d == k ? double(P[d] > 0 ? 1 : -1) : std::tan(q * double(P[d]) / double(N));
    const double len = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    for (int d = 0; d < 3; ++d) unit[3 * v + d] = c[d] / len;

    const int32_t t[2] = {(k + 1) % 3, (k + 2) % 3};
    for (int ti = 0; ti < 2; ++ti) {
      for (int di = 0; di < 2; ++di) {
        const int32_t dir = di == 0 ? 1 : -1;
        int32_t Q[3] = {P[0], P[1], P[2]};
        const int32_t ax = t[ti];
        if (iabs(P[ax] + 2 * dir) <= N - 1) {
          Q[ax] = P[ax] + 2 * dir;
        } else {  // across the cube edge onto the face with normal ax
          Q[ax] = dir * N;
          Q[k] = (P[k] > 0 ? 1 : -1) * (N - 1);
        }
        nbr[4 * v + 2 * ti + di] = index_of(Q);
      }
    }
  }

  // Loops: walk counter-clockwise around each axis.
  for (uint32_t axis = 0; axis < 3; ++axis) {
    const int32_t a1 = int32_t((axis + 1) % 3), a2 = int32_t((axis + 2) % 3);
    for (uint32_t level = 0; level < n; ++level) {
      const uint32_t l = axis * n + level;
      int32_t P[3];
      P[axis] = -(N - 1) + 2 * int32_t(level);
      P[a1] = N;            // start on the face with normal +a1
      P[a2] = -(N - 1);
      uint32_t v = index_of(P), prev = kNone;
      for (uint32_t p = 0; p < loop_len; ++p) {
        loops[l * loop_len + p] = v;
        // Pick the neighbour at the same level that turns counter-clockwise.
        int32_t Pv[3];
        coords_of(v, Pv);
        uint32_t next = kNone;
        for (int j = 0; j < 4; ++j) {
          const uint32_t w = nbr[4 * v + j];
          if (w == prev) continue;
          int32_t Pw[3];
          coords_of(w, Pw);
          if (Pw[axis] != Pv[axis]) continue;
          const int64_t cross = int64_t(Pv[a1]) * Pw[a2] - int64_t(Pv[a2]) * Pw[a1];
          if (cross > 0) { next = w; break; }
        }
        prev = v;
        v = next;
      }
    }
  }
  for (uint32_t i = 0; i < 2 * nv; ++i) vloop[i] = kNone;
  for (uint32_t l = 0; l < nloops; ++l)
    for (uint32_t p = 0; p < loop_len; ++p) {
      const uint32_t v = loops[l * loop_len + p];
      const uint32_t slot = vloop[2 * v] == kNone ? 0 : 1;
      vloop[2 * v + slot] = l;
      vpos[2 * v + slot] = p;
    }

  // Faces around every grid corner on the cube surface, ordered
  // counter-clockwise seen from outside.
  uint32_t nq = 0, nt = 0;
  const uint32_t first_tri = nfaces - 8;
  for (int32_t x = -N; x <= N; x += 2)
    for (int32_t y = -N; y <= N; y += 2)
      for (int32_t z = -N; z <= N; z += 2) {
        const int32_t C[3] = {x, y, z};
        int on = 0;
        for (int d = 0; d < 3; ++d) on += iabs(C[d]) == N;
        if (on == 0) continue;
        uint32_t cell[4];
        double ang[4];
        int m = 0;
        // Tangent frame around the outward direction C.
        const double cl = std::sqrt(double(x) * x + double(y) * y + double(z) * z);
        const double nc[3] = {x / cl, y / cl, z / cl};
        double e1[3], e2[3];
        tangent_frame(nc, e1, e2);
        for (int k = 0; k < 3; ++k) {
          if (iabs(C[k]) != N) continue;
          const int t1 = (k + 1) % 3, t2 = (k + 2) % 3;
          for (int d1 = -1; d1 <= 1; d1 += 2)
            for (int d2 = -1; d2 <= 1; d2 += 2) {
              int32_t P[3];
              P[k] = C[k];
              P[t1] = C[t1] + d1;
              P[t2] = C[t2] + d2;
              if (iabs(P[t1]) > N - 1 || iabs(P[t2]) > N - 1) continue;
              double r[3];
              for (int d = 0; d < 3; ++d) r[d] = double(P[d]) - double(C[d]);
              const double u = r[0] * e1[0] + r[1] * e1[1] + r[2] * e1[2];
              const double w = r[0] * e2[0] + r[1] * e2[1] + r[2] * e2[2];
              cell[m] = index_of(P);
              ang[m] = std::atan2(w, u);
              ++m;
            }
        }
        // Insertion sort by angle: counter-clockwise around the outward normal.
        for (int i = 1; i < m; ++i)
          for (int j = i; j > 0 && ang[j] < ang[j - 1]; --j) {
            const double ta = ang[j]; ang[j] = ang[j - 1]; ang[j - 1] = ta;
            const uint32_t tc = cell[j]; cell[j] = cell[j - 1]; cell[j - 1] = tc;
          }
        const uint32_t f = m == 4 ? nq++ : first_tri + nt++;
        for (int i = 0; i < 4; ++i) faces[4 * f + i] = i < m ? cell[i] : kNone;
      }

  // Faces around each vertex (every cell touches four grid corners), then the
  // face across each face edge.
  for (uint32_t i = 0; i < 4 * nv; ++i) vfaces[i] = kNone;
  for (uint32_t f = 0; f < nfaces; ++f)
    for (int e = 0; e < 4; ++e) {
      const uint32_t v = faces[4 * f + e];
      if (v == kNone) continue;
      uint32_t* vf = vfaces + 4 * size_t(v);
      int k = 0;
      while (k < 4 && vf[k] != kNone) ++k;
      if (k < 4) vf[k] = f;
    }
  for (uint32_t f = 0; f < nfaces; ++f) {
    const int k = faces[4 * f + 3] == kNone ? 3 : 4;
    for (int e = 0; e < 4; ++e) {
      fadj[4 * f + e] = kNone;
      if (e >= k) continue;
      const uint32_t a = faces[4 * f + e], b = faces[4 * f + (e + 1) % k];
      for (int q = 0; q < 4; ++q) {
        const uint32_t g = vfaces[4 * size_t(a) + q];
        if (g == kNone || g == f) continue;
        const int kg = faces[4 * g + 3] == kNone ? 3 : 4;
        for (int t = 0; t < kg; ++t)
          if (faces[4 * g + t] == b && faces[4 * g + (t + 1) % kg] == a) fadj[4 * f + e] = g;
      }
    }
  }
}

}  // namespace ffseg
