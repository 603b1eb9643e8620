#include "patch_certificate.h"

#include <algorithm>
#include <cmath>

#include "tangent_frame.h"

namespace ffseg {

namespace {

// Clusters are blocks of block x block grid corners of a cube face; the
// corners on a cube edge or at a cube corner go to the face of the lowest
// axis. Corner positions along a face run 0..n, so n / block + 1 blocks.
inline uint32_t blocks_per_side(uint32_t n, uint32_t block) { return n / block + 1; }

// Raw cluster of face f: the block of the grid corner it surrounds (the mean
// of its cells' lattice points, pushed onto the cube's surface where it lies
// off a face). Assigning by corner keeps the union of neighbouring clusters a
// rectangle of faces, unfolded across cube edges, so a window's boundary is
// straight and its projection star-shaped.
inline uint32_t face_raw_cluster(const CubeSphere& m, uint32_t f, uint32_t block) {
  const int32_t N = int32_t(m.n);
  const int k = m.face_size(f);
  int32_t sum[3] = {0, 0, 0};
  for (int e = 0; e < k; ++e) {
    int32_t P[3];
    m.coords_of(m.faces[4 * size_t(f) + e], P);
    for (int d = 0; d < 3; ++d) sum[d] += P[d];
  }
  int32_t C[3];
  for (int d = 0; d < 3; ++d) {
    // |mean| > N - 1: the corner lies on the cube's boundary in axis d.
    if (sum[d] > k * (N - 1)) C[d] = N;
    else if (sum[d] < -k * (N - 1)) C[d] = -N;
    else C[d] = sum[d] / k;  // interior: the mean of two pairs differing by 2, exact
  }
  int ax = 0;
  while (ax < 3 && C[ax] != N && C[ax] != -N) ++ax;
  if (ax == 3) ax = 0;  // not reached on a cube-sphere
  const uint32_t F = uint32_t(2 * ax + (C[ax] > 0 ? 1 : 0));
  const uint32_t c1 = uint32_t((C[(ax + 1) % 3] + N) / 2), c2 = uint32_t((C[(ax + 2) % 3] + N) / 2);
  const uint32_t side = blocks_per_side(m.n, block);
  return (F * side + c1 / block) * side + c2 / block;
}



}  // namespace

void PatchCertificate::carve(Arena& a, const CubeSphere& m) {
  block = m.n <= kSmallMesh ? 2 : 4;
  fail_share = m.n <= kSmallMesh ? 1 : 8;
  const uint32_t side = blocks_per_side(m.n, block);
  const uint32_t cap = 6 * side * side;  // clusters before dropping empty ones
  face_cluster = a.alloc<uint32_t>(m.nfaces);
  cl_ptr = a.alloc<uint32_t>(size_t(cap) + 1);
  cl_faces = a.alloc<uint32_t>(m.nfaces);
  tri_ptr = a.alloc<uint32_t>(size_t(cap) + 1);
  cl_tris = a.alloc<uint32_t>(m.triangle_count());
  // 6 per cluster fit in 3 per triangle from n = 3 on.
  tn = a.alloc<double>(std::max(size_t(3) * m.triangle_count(), size_t(6) * cap));
  tmargin = a.alloc<double>(m.triangle_count());
  ntri = m.triangle_count();
  pbox = a.alloc<double>(size_t(6) * ntri);
  nb_cnt = a.alloc<uint32_t>(cap);
  nb = a.alloc<uint32_t>(size_t(kMaxNeighbours) * cap);
  loop_ptr = a.alloc<uint32_t>(size_t(cap) + 1);
  // A window of 3 x 3 blocks has about 12 block boundary vertices; longer
  // loops (never on a regular cube-sphere) leave the window uncertified.
  loop_cap = cap * (16 * block + 32);
  loop = a.alloc<uint32_t>(loop_cap);
  box = a.alloc<double>(size_t(6) * cap);
  nsum = a.alloc<double>(size_t(3) * cap);
  order = a.alloc<uint32_t>(cap);
  failed = a.alloc<uint32_t>(cap);
  is_failed = a.alloc<uint8_t>(cap);
  face_mark = a.alloc<uint8_t>(m.nfaces);
  vert_mark = a.alloc<uint8_t>(m.nv);
  next = a.alloc<uint32_t>(m.nv);
  built = false;
}

void PatchCertificate::build(const CubeSphere& m) {
  const uint32_t nb_side = blocks_per_side(m.n, block);
  const uint32_t cap = 6 * nb_side * nb_side;
  // Raw clusters, then drop the empty ones (renumbered in order).
  uint32_t* count = nb_cnt;  // reused as scratch before the neighbour lists
  for (uint32_t c = 0; c < cap; ++c) count[c] = 0;
  for (uint32_t f = 0; f < m.nfaces; ++f) ++count[face_raw_cluster(m, f, block)];
  uint32_t* renum = order;  // scratch
  ncl = 0;
  for (uint32_t c = 0; c < cap; ++c) renum[c] = count[c] ? ncl++ : kNone;
  for (uint32_t f = 0; f < m.nfaces; ++f) face_cluster[f] = renum[face_raw_cluster(m, f, block)];
  for (uint32_t c = 0; c <= ncl; ++c) cl_ptr[c] = 0;
  for (uint32_t f = 0; f < m.nfaces; ++f) ++cl_ptr[face_cluster[f] + 1];
  for (uint32_t c = 0; c < ncl; ++c) cl_ptr[c + 1] += cl_ptr[c];
  for (uint32_t c = 0; c < ncl; ++c) count[c] = cl_ptr[c];
  for (uint32_t f = 0; f < m.nfaces; ++f) cl_faces[count[face_cluster[f]]++] = f;
  uint32_t nt = 0;
  for (uint32_t c = 0; c < ncl; ++c) {
    tri_ptr[c] = nt;
    for (uint32_t i = cl_ptr[c]; i < cl_ptr[c + 1]; ++i) {
      const uint32_t f = cl_faces[i];
      const uint32_t t0 = m.first_triangle(f);
      for (uint32_t t = t0; t < t0 + (m.face_size(f) == 3 ? 1u : 2u); ++t) cl_tris[nt++] = t;
    }
  }
  tri_ptr[ncl] = nt;
  // Window clusters: C, then the owners of faces sharing a vertex with C's faces.
  for (uint32_t c = 0; c < ncl; ++c) {
    uint32_t* p = nb + size_t(kMaxNeighbours) * c;
    uint32_t k = 0;
    p[k++] = c;
    bool overflow = false;
    for (uint32_t i = cl_ptr[c]; i < cl_ptr[c + 1]; ++i) {
      const uint32_t f = cl_faces[i];
      const uint32_t* q = m.faces + 4 * size_t(f);
      for (int j = 0; j < m.face_size(f); ++j)
        for (int r = 0; r < 4; ++r) {
          const uint32_t g = m.vfaces[4 * size_t(q[j]) + r];
          if (g == kNone) continue;
          const uint32_t d = face_cluster[g];
          bool seen = false;
          for (uint32_t t = 0; t < k && !seen; ++t) seen = p[t] == d;
          if (seen) continue;
          if (k == kMaxNeighbours) {
            overflow = true;
            continue;
          }
          p[k++] = d;
        }
    }
    nb_cnt[c] = k;
    for (uint32_t t = k; t < kMaxNeighbours; ++t) p[t] = kNone;  // neighbours() reads every slot
    (void)overflow;  // clusters left out are covered by the far pairs
  }
  // Boundary loops of the windows.
  for (uint32_t f = 0; f < m.nfaces; ++f) face_mark[f] = 0;
  for (uint32_t v = 0; v < m.nv; ++v) {
    vert_mark[v] = 0;
    next[v] = kNone;
  }
  uint32_t used = 0;
  for (uint32_t c = 0; c < ncl; ++c) {
    loop_ptr[c] = used;
    const uint32_t* p = nb + size_t(kMaxNeighbours) * c;
    uint32_t nf = 0, nedge2 = 0, nverts = 0, nbound = 0, start = kNone;
    bool ok = true;
    for (uint32_t i = 0; i < nb_cnt[c]; ++i)
      for (uint32_t j = cl_ptr[p[i]]; j < cl_ptr[p[i] + 1]; ++j) face_mark[cl_faces[j]] = 1;
    for (uint32_t i = 0; i < nb_cnt[c]; ++i)
      for (uint32_t j = cl_ptr[p[i]]; j < cl_ptr[p[i] + 1]; ++j) {
        const uint32_t f = cl_faces[j];
        const uint32_t* q = m.faces + 4 * size_t(f);
        const int k = m.face_size(f);
        ++nf;
        nedge2 += uint32_t(k);
        for (int e = 0; e < k; ++e) {
          if (!vert_mark[q[e]]) {
            vert_mark[q[e]] = 1;
            ++nverts;
          }
          const uint32_t g = m.fadj[4 * size_t(f) + e];
          if (g != kNone && face_mark[g]) continue;
          // Boundary edge q[e] -> q[e+1]: the window lies on its left.
          const uint32_t a = q[e], b = q[(e + 1) % k];
          if (next[a] != kNone) ok = false;  // two boundary edges leave a: pinched
          next[a] = b;
          ++nbound;
          if (start == kNone) start = a;
        }
      }
    // Euler characteristic V - E + F with E = (sum of face sizes + boundary edges) / 2.
    const int64_t chi = int64_t(nverts) - int64_t(nedge2 + nbound) / 2 + int64_t(nf);
    if (chi != 1 || start == kNone) ok = false;
    if (ok) {
      uint32_t v = start, len = 0;
      do {
        if (used + len >= loop_cap || next[v] == kNone) {
          ok = false;
          break;
        }
        loop[used + len++] = v;
        v = next[v];
      } while (v != start && len <= nbound);
      if (ok && (v != start || len != nbound)) ok = false;  // not one loop
      if (ok) used += len;
    }
    // Clear the marks.
    for (uint32_t i = 0; i < nb_cnt[c]; ++i)
      for (uint32_t j = cl_ptr[p[i]]; j < cl_ptr[p[i] + 1]; ++j) {
        const uint32_t f = cl_faces[j];
        face_mark[f] = 0;
        const uint32_t* q = m.faces + 4 * size_t(f);
        for (int e = 0; e < m.face_size(f); ++e) {
          vert_mark[q[e]] = 0;
          next[q[e]] = kNone;
        }
      }
  }
  loop_ptr[ncl] = used;
  for (uint32_t c = 0; c < ncl; ++c) order[c] = c;
  built = true;
}

bool PatchCertificate::certify(const double* x, const double* normals,
                               const double* lo, const double* hi, uint32_t max_failed) {
  nfailed = 0;
  if (!built) return false;
  // Cluster boxes and normal sums; the triangles' normals and orientation
  // margins packed in cluster order. The rounding of n_t is at most about
  // 1e-15 e^2, e the extent of the triangle's box: slivers need the second
  // term of the margin.
  for (uint32_t c = 0; c < ncl; ++c) {
    // Accumulated in locals (the outputs may alias the inputs as far as the
    // compiler knows, which kept them in memory), stored after the loop.
    double b[6] = {HUGE_VAL, HUGE_VAL, HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double s[3] = {0, 0, 0};
    for (uint32_t k = tri_ptr[c]; k < tri_ptr[c + 1]; ++k) {
      const uint32_t t = cl_tris[k];
      const double* n = normals + 3 * size_t(t);
      const double* tl = lo + 3 * size_t(t);
      const double* th = hi + 3 * size_t(t);
      double e = 0;
      for (int a = 0; a < 3; ++a) {
        b[a] = tl[a] < b[a] ? tl[a] : b[a];
        b[3 + a] = th[a] > b[3 + a] ? th[a] : b[3 + a];
        s[a] += n[a];
        e = th[a] - tl[a] > e ? th[a] - tl[a] : e;
        tn[3 * size_t(k) + a] = n[a];
        pbox[a * size_t(ntri) + k] = tl[a];
        pbox[(3 + a) * size_t(ntri) + k] = th[a];
      }
      tmargin[k] = 1e-6 * (std::fabs(n[0]) + std::fabs(n[1]) + std::fabs(n[2])) + 1e-12 * e * e;
    }
    for (int a = 0; a < 6; ++a) box[6 * size_t(c) + a] = b[a];
    for (int a = 0; a < 3; ++a) nsum[3 * size_t(c) + a] = s[a];
    if (!(std::isfinite(b[0]) && std::isfinite(b[1]) && std::isfinite(b[2]) && std::isfinite(b[3]) &&
          std::isfinite(b[4]) && std::isfinite(b[5])))
      return false;  // non-finite positions: the exact check decides
  }
  // Clusters by box lo x, ties in their order of the last call: the stable
  // sort of the last call's order, which is its sort by key and position.
  // (An insertion sort made it: quick from the same mesh's order, but the
  // objects sharing this scratch take turns, and from another object's
  // order it took about ncl^2 / 4 moves.) The positions are sorted in
  // `failed`, free until the windows below.
  bool sorted = true;
  for (uint32_t i = 1; i < ncl && sorted; ++i) sorted = !(box[6 * size_t(order[i - 1])] > box[6 * size_t(order[i])]);
  if (!sorted) {
    for (uint32_t i = 0; i < ncl; ++i) failed[i] = i;
    std::sort(failed, failed + ncl, [&](uint32_t p, uint32_t q) {
      const double kp = box[6 * size_t(order[p])], kq = box[6 * size_t(order[q])];
      return kp < kq || (kp == kq && p < q);
    });
    for (uint32_t i = 0; i < ncl; ++i) failed[i] = order[failed[i]];
    for (uint32_t i = 0; i < ncl; ++i) order[i] = failed[i];
  }
  // Windows.
  for (uint32_t c = 0; c < ncl; ++c) {
    bool ok = loop_ptr[c + 1] > loop_ptr[c];
    const uint32_t* p = nb + size_t(kMaxNeighbours) * c;
    double u[3] = {0, 0, 0}, v[3] = {0, 0, 0}, w[3] = {0, 0, 0};
    if (ok) {
      double d[3] = {0, 0, 0};
      for (uint32_t i = 0; i < nb_cnt[c]; ++i)
        for (int a = 0; a < 3; ++a) d[a] += nsum[3 * size_t(p[i]) + a];
      const double dl = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      ok = dl > 0 && std::isfinite(dl);
      if (ok) {
        for (int a = 0; a < 3; ++a) d[a] /= dl;
        tangent_frame(d, u, v);
        // The projection (p.u, p.v) runs along w = u x v (as computed).
        w[0] = u[1] * v[2] - u[2] * v[1];
        w[1] = u[2] * v[0] - u[0] * v[2];
        w[2] = u[0] * v[1] - u[1] * v[0];
      }
    }
    // Every triangle of the window projects counter-clockwise, by a margin
    // (cos > 1e-6 against w, plus a sliver term) far above the rounding of
    // n_t and of n_t . w (tn, tmargin: packed in cluster order above).
    for (uint32_t i = 0; i < nb_cnt[c] && ok; ++i) {
      const uint32_t d = p[i];
      uint32_t bad = 0;
      for (uint32_t k = tri_ptr[d]; k < tri_ptr[d + 1]; ++k) {
        const double* n = tn + 3 * size_t(k);
        bad += !(n[0] * w[0] + n[1] * w[1] + n[2] * w[2] > tmargin[k]);
      }
      ok = bad == 0;
    }
    // The projected loop is strictly star-shaped around its vertices' mean
    // and winds once. Margin: 1e-9 L^2 (L the loop's projected extent) on
    // each orientation, against rounding of about 1e-15 (|p| / L) L^2 in the
    // projected coordinates (positions within 1e5 L of the origin).
    if (ok) {
      const uint32_t b0 = loop_ptr[c], b1 = loop_ptr[c + 1];
      double cx = 0, cy = 0, lx = HUGE_VAL, hx = -HUGE_VAL, ly = HUGE_VAL, hy = -HUGE_VAL, pmax = 0;
      for (uint32_t i = b0; i < b1; ++i) {
        const double* q = x + 3 * size_t(loop[i]);
        const double px = q[0] * u[0] + q[1] * u[1] + q[2] * u[2];
        const double py = q[0] * v[0] + q[1] * v[1] + q[2] * v[2];
        cx += px;
        cy += py;
        lx = px < lx ? px : lx;
        hx = px > hx ? px : hx;
        ly = py < ly ? py : ly;
        hy = py > hy ? py : hy;
        const double pa = std::fabs(q[0]) + std::fabs(q[1]) + std::fabs(q[2]);
        pmax = pa > pmax ? pa : pmax;
      }
      cx /= double(b1 - b0);
      cy /= double(b1 - b0);
      const double L = (hx - lx) > (hy - ly) ? (hx - lx) : (hy - ly);
      ok = L > 0 && pmax < 1e5 * L;
      const double tol = 1e-9 * L * L;
      uint32_t crossings = 0;
      const double* q0 = x + 3 * size_t(loop[b1 - 1]);
      double ax = q0[0] * u[0] + q0[1] * u[1] + q0[2] * u[2] - cx;
      double ay = q0[0] * v[0] + q0[1] * v[1] + q0[2] * v[2] - cy;
      for (uint32_t i = b0; i < b1 && ok; ++i) {
        const double* q = x + 3 * size_t(loop[i]);
        const double bx = q[0] * u[0] + q[1] * u[1] + q[2] * u[2] - cx;
        const double by = q[0] * v[0] + q[1] * v[1] + q[2] * v[2] - cy;
        if (!(ax * by - ay * bx > tol)) ok = false;
        // Counter-clockwise edges cross the ray from the centre along +u
        // upwards only: count them (half-open in y).
        if (ay < 0 && by >= 0 && ax * by - ay * bx > 0) ++crossings;
        ax = bx;
        ay = by;
      }
      if (ok && crossings != 1) ok = false;
    }
    is_failed[c] = !ok;
    if (!ok) {
      if (nfailed == max_failed) return false;
      failed[nfailed++] = c;
    }
  }
  for (uint32_t i = 0; i < ncl; ++i)
    for (int a = 0; a < 6; ++a) tn[6 * size_t(i) + a] = box[6 * size_t(order[i]) + a];
  return true;
}

}  // namespace ffseg
